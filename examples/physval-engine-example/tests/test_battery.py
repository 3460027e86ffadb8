"""physval's case battery on this package's engine, `mujoco-soft`: the conformance battery
and every case variant it can represent, each judged by its closed form, its tolerance and
the known deviations this package ships (xfails/mujoco-soft.txt). It needs physval and
this package installed, not a physval checkout:

    pytest tests/test_battery.py                 # the whole battery (about 190 tests)
    pytest tests/test_battery.py -k conformance  # the conformance battery only
"""
import pytest

from physval.testing import check, engine_checks


@pytest.mark.parametrize("job", engine_checks(["mujoco-soft"]))
def test_battery(job):
    check(job)
