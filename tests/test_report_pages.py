"""The run report a person opens: report.md holds the summary, the counts and an index;
the listings (every known deviation, every unsupported reason, the knobs) and each family's
detail live on pages of their own, one click away, and every link resolves."""
from __future__ import annotations

import re
from pathlib import Path

from physval.cli import main

FAKE = f"{Path(__file__).with_name('fakes.py')}:FakeAdapter"


def test_the_report_links_its_detail_pages(tmp_path):
    out = tmp_path / "out"  # pymunk is 2D: the 3D drop is unsupported there
    assert main(["run", "--cases", "central_impact[drop,e=0.5]", "conformance[free_fall*]", "--engines", "reference",
                 "mujoco", "pymunk", "fake", "--adapter", FAKE, "--quiet", "--readings", "none", "--out", str(out)]) == 0
    report = (out / "report.md").read_text()
    links = re.findall(r"\]\(([^)#]+\.(?:md|png))\)", report)
    assert {"deviations.md", "unsupported.md", "knobs.md", "families/central_impact.md",
            "families/conformance.md"} <= set(links)
    for link in links:
        assert (out / link).is_file(), link
    page = (out / "families" / "central_impact.md").read_text()
    for link in re.findall(r"\]\(([^)#]+)\)", page):
        assert (out / "families" / link).resolve().is_file(), link
    assert "Tolerances:" in page and "Measured values:" in page and "Tolerances:" not in report
    # a second run of one family drops the other family's page: the index links none
    assert main(["run", "--cases", "central_impact[drop,e=0.5]", "--engines", "reference", "--quiet",
                 "--readings", "none", "--out", str(out)]) == 0
    assert not (out / "families" / "conformance.md").exists()
