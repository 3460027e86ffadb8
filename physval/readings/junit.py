"""A run's checks as a JUnit XML report, for an engine's CI (`physval run --junitxml FILE`):
one test case per check, one test suite per family. A pass is a plain test case; a fail
a <failure> with the measured size, the tolerance and its reason, and the command that
reproduces it; an error or an unstable run an <error>; a known deviation a <skipped> of
type "deviation" with its cause and band (the way pytest writes an expected failure); an
unsupported run a <skipped> of type "unsupported" with the reason. The gate itself is
`--fail-on` (`gate` below), so a CI reads both from one run.
"""
from __future__ import annotations

import math
import re
import shlex
import xml.etree.ElementTree as ET
from collections import Counter
from pathlib import Path

from physval.core.verdicts import CHANGED, VANISHED
from physval.files import write_atomic

# what --fail-on accepts: a status, or a known deviation that moved
GATES = ("fail", "error", "unstable", "deviation", "unsupported", "changed", "vanished")


def gate_of(row: dict) -> set[str]:
    """The --fail-on categories a row falls in."""
    status, reason = row.get("status", ""), str(row.get("reason", ""))
    out = {status}
    if status == "fail" and reason.startswith(CHANGED):
        out.add("changed")
    if status in ("pass", "fail") and reason.startswith(VANISHED):
        out.add("vanished")
    return out


def gate(rows: list[dict], fail_on: set[str]) -> Counter:
    """How many rows fall in each category of `fail_on` (empty: the gate passes)."""
    return Counter(g for r in rows for g in gate_of(r) & fail_on)


def reproduce(row: dict) -> str:
    """The command that runs this check's job again, at its settings."""
    words = ["physval", "run", "--cases", f"{row['case']}[{row['variant']}]", "--engines", row["engine"]]
    if str(row.get("dt", "")).strip():
        words += ["--dt", f"{float(row['dt']):g}"]
    if str(row.get("iterations", "")).strip():
        words += ["--iterations", str(row["iterations"])]
    return " ".join(shlex.quote(w) for w in words)


def _number(x) -> str:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return str(x)
    return f"{v:.6g}" if math.isfinite(v) else str(v)


def testcase(row: dict) -> ET.Element:
    case = ET.Element("testcase", classname=f"physval.{row['case']}.{row['engine']}",
                      name=f"{row['case']}[{row['variant']}]:{row['metric']}-{row['engine']}")
    try:
        case.set("time", f"{float(row.get('wall_s') or 0):.6f}")
    except ValueError:
        pass
    status, reason = row["status"], str(row.get("reason", ""))
    size = (f"measured {_number(row.get('measured'))} {row.get('unit', '')}, expected {_number(row.get('expected'))}, "
            f"tolerance {_number(row.get('tolerance'))} ({row.get('tolerance_kind', '')}: "
            f"{row.get('tolerance_reason', '')})")
    if status == "fail":
        ET.SubElement(case, "failure", message=f"{size}; {reason}", type="fail").text = (
            f"{size}\n{reason}\nreproduce: {reproduce(row)}")
    elif status in ("error", "unstable"):
        ET.SubElement(case, "error", message=reason, type=status).text = f"{reason}\nreproduce: {reproduce(row)}"
    elif status == "deviation":
        ET.SubElement(case, "skipped", message=f"known deviation: {row.get('known_deviation', '')} "
                                               f"[band {row.get('band', '')}]; {size}", type="deviation")
    elif status == "unsupported":
        ET.SubElement(case, "skipped", message=reason, type="unsupported")
    elif reason:  # a pass with something to say (a known deviation that vanished)
        ET.SubElement(case, "system-out").text = reason
    return case


# What XML 1.0 forbids in a document (its Char production), even escaped: C0 controls but tab,
# newline and carriage return, lone surrogates, U+FFFE and U+FFFF. An engine's message may
# carry them (ANSI colour codes: ESC, U+001B), and a reader rejects the whole file for one.
NOT_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")


def xml_text(text: str) -> str:
    """`text` with each character XML 1.0 forbids written out as its escape (ESC: '\\x1b')."""
    return NOT_XML.sub(lambda m: m[0].encode("unicode_escape", "backslashreplace").decode("ascii"), text)


def _xml_chars(root: ET.Element) -> None:
    for element in root.iter():
        element.text = xml_text(element.text) if element.text else element.text
        element.attrib.update({k: xml_text(v) for k, v in element.attrib.items()})


def write(rows: list[dict], path: Path, name: str = "physval") -> Path:
    """The JUnit XML of `rows` at `path`; one test suite per family, in the rows' order."""
    root = ET.Element("testsuites", name=name)
    suites: dict[str, list[dict]] = {}
    for r in rows:
        suites.setdefault(r["case"], []).append(r)
    totals = Counter()
    for family, mine in suites.items():
        n = Counter(r["status"] for r in mine)
        counts = {"tests": len(mine), "failures": n["fail"], "errors": n["error"] + n["unstable"],
                  "skipped": n["deviation"] + n["unsupported"]}
        totals.update(counts)
        suite = ET.SubElement(root, "testsuite", name=family, **{k: str(v) for k, v in counts.items()})
        suite.extend(testcase(r) for r in mine)
    root.attrib.update({k: str(totals[k]) for k in ("tests", "failures", "errors", "skipped")})
    _xml_chars(root)
    ET.indent(root)
    write_atomic(Path(path), ET.tostring(root, encoding="unicode", xml_declaration=True) + "\n")
    return Path(path)
