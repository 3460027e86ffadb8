"""report.html, the run's report as a static site, opened in a real browser: Debian's
Chromium driven by Selenium through its chromedriver, headless, from file:// URLs (no
server, no network). Every page loads without a console error, every link resolves, a
filter narrows a table and a heading sorts it, and the index is photographed. Without
/usr/bin/chromium (or selenium) the browser test skips and says why; the link check runs
without a browser."""
from __future__ import annotations

import csv
import re

import shutil
import time
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlparse

import pytest

from adapters.registry import available
from physval.cli import main

CHROMIUM, CHROMEDRIVER = Path("/usr/bin/chromium"), Path("/usr/bin/chromedriver")
# without the background-networking flags Chromium reaches for its update and sync servers,
# and this closed network refuses the connections (logged as errors, slow to time out)
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--window-size=1400,1000")


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """A small run's result folder (report.html and its pages)."""
    out = tmp_path_factory.mktemp("site") / "out"
    engines = "reference,mujoco" if available("mujoco") else "reference"
    assert main(["run", "--cases", "central_impact", "--engines", engines, "--quiet", "--workers", "1",
                 "--readings", "none", "--out", str(out)]) == 0
    return out


class _Links(HTMLParser):
    def __init__(self):
        super().__init__()
        self.found = []

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag in ("a", "img") and (attrs.get("href") or attrs.get("src")):
            self.found.append(attrs.get("href") or attrs.get("src"))


def pages(out: Path) -> list[Path]:
    return [out / "report.html"] + sorted((out / "html").rglob("*.html"))


def test_every_page_links_only_files_beside_it(site):
    """Every href and src is relative and names a file of the folder (no network, no CDN),
    and the anchor it names exists on that page."""
    assert {p.relative_to(site).as_posix() for p in pages(site)} >= {
        "report.html", "html/families/central_impact.html", "html/engines/reference.html"}
    for page in pages(site):
        parser = _Links()
        parser.feed(page.read_text())
        assert parser.found, page
        for link in parser.found:
            assert not urlparse(link).scheme, f"{page.name}: {link}"
            path, _, anchor = link.partition("#")
            target = (page.parent / path).resolve() if path else page
            assert target.is_file(), f"{page.name}: {link}"
            if anchor:
                assert f'id="{anchor}"' in target.read_text(), f"{page.name}: {link}"


def test_no_two_elements_of_a_page_share_an_id(site):
    """A filter box names its table by id: a page whose sections repeat an id filters the wrong one."""
    for page in pages(site):
        ids = re.findall(r' id="([^"]+)"', page.read_text())
        assert len(ids) == len(set(ids)), (page.name, sorted({i for i in ids if ids.count(i) > 1}))


def test_the_site_rebuilds_from_the_results_csv(site, tmp_path):
    """`python3 -m physval.readings.results FOLDER` draws the same report, family and engine
    pages from results.csv and knobs.json alone (report.md differs only in its date)."""
    from physval.readings.results import main
    copy = tmp_path / "copy"
    shutil.copytree(site, copy)
    for page in (copy / "html").rglob("*.html"):
        page.unlink()
    (copy / "report.html").unlink()
    assert main([str(copy)]) == 0
    for page in (site / "html").rglob("*.html"):
        assert (copy / page.relative_to(site)).read_text() == page.read_text(), page.name
    undated = [[line for line in (folder / "report.md").read_text().splitlines() if "date (UTC)" not in line]
               for folder in (site, copy)]
    assert undated[0] == undated[1]
    assert "Scorecard" in (copy / "report.html").read_text()


class _Headings(HTMLParser):
    """The h2 and h3 headings of a page, in order."""

    def __init__(self):
        super().__init__()
        self.found, self._in = [], None

    def handle_starttag(self, tag, attrs):
        if tag in ("h2", "h3"):
            self._in = [int(tag[1]), ""]

    def handle_data(self, data):
        if self._in is not None:
            self._in[1] += data

    def handle_endtag(self, tag):
        if self._in is not None and tag == f"h{self._in[0]}":
            self.found.append(tuple(self._in))
            self._in = None


def test_report_md_and_report_html_carry_the_same_sections_in_the_same_order(site):
    from physval.report import titles
    parser = _Headings()
    parser.feed((site / "report.html").read_text())
    md = titles((site / "report.md").read_text())
    assert [t for _, t in md][:3] == ["Contents", "Scorecard", "Closest to physics"]
    assert parser.found == md


def _browser(tmp_path):
    if not CHROMIUM.is_file() or not CHROMEDRIVER.is_file():
        pytest.skip(f"no browser: {CHROMIUM} and {CHROMEDRIVER} come with `apt-get install chromium chromium-driver`")
    webdriver = pytest.importorskip("selenium.webdriver", reason="selenium is in the test extra")
    from selenium.webdriver.chrome.service import Service
    options = webdriver.ChromeOptions()
    options.binary_location = str(CHROMIUM)
    for flag in FLAGS + (f"--user-data-dir={tmp_path / 'profile'}",):
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(str(CHROMEDRIVER)), options=options)


def test_the_site_in_a_browser(site, tmp_path):
    from selenium.webdriver.common.by import By
    started = time.monotonic()
    driver = _browser(tmp_path)
    try:
        for page in pages(site):
            driver.get(page.as_uri())
            assert driver.title.endswith("- physval"), page
            errors = [e["message"] for e in driver.get_log("browser") if e["level"] == "SEVERE"]
            assert not errors, f"{page.name}: {errors}"
            for a in driver.find_elements(By.CSS_SELECTOR, "a[href], img[src]"):
                url = a.get_attribute("href") or a.get_attribute("src")
                assert url.startswith("file://"), f"{page.name}: {url}"
                assert Path(unquote(urlparse(url).path)).is_file(), f"{page.name}: {url}"
            for img in driver.find_elements(By.TAG_NAME, "img"):
                assert driver.execute_script("return arguments[0].naturalWidth", img) > 0, img.get_attribute("src")

        driver.get((site / "html" / "families" / "central_impact.html").as_uri())
        rows = driver.find_elements(By.CSS_SELECTOR, "#t-measured tbody tr")
        box = driver.find_element(By.CSS_SELECTOR, "input.filter[data-table=t-measured]")
        box.send_keys("energy_lost")
        shown = [r for r in rows if r.is_displayed()]
        assert 0 < len(shown) < len(rows) and all("energy_lost" in r.text for r in shown)
        assert driver.find_element(By.ID, "t-measured-count").text == f"{len(shown)} of {len(rows)} rows"
        box.clear()
        box.send_keys(" ")  # an empty filter shows every row again
        assert all(r.is_displayed() for r in rows)

        heading = driver.find_elements(By.CSS_SELECTOR, "#t-measured thead th")[0]  # variant
        heading.click()
        heading.click()  # descending
        variants = [r.find_elements(By.TAG_NAME, "td")[0].text
                    for r in driver.find_elements(By.CSS_SELECTOR, "#t-measured tbody tr")]
        assert variants == sorted(variants, reverse=True)
        assert not [e for e in driver.get_log("browser") if e["level"] == "SEVERE"]  # the scripts ran clean

        driver.get((site / "report.html").as_uri())
        assert driver.find_element(By.ID, "scorecard").is_displayed()
        # a click on an effect's heading orders the engines by their rank on it, the closest first
        headings = driver.find_elements(By.CSS_SELECTOR, "#t-scorecard thead th")
        column = [h.text for h in headings].index("restitution")
        def ranks():
            return [int(r.find_elements(By.TAG_NAME, "td")[column].get_attribute("data-key"))
                    for r in driver.find_elements(By.CSS_SELECTOR, "#t-scorecard tbody tr")]
        headings[column].click()
        assert ranks() == sorted(ranks())
        headings[column].click()  # descending: the farthest first (it reorders the rows the page opened with)
        assert ranks() == sorted(ranks(), reverse=True)
        shot = tmp_path / "index.png"
        assert driver.save_screenshot(str(shot)) and shot.stat().st_size > 10_000
    finally:
        driver.quit()
    print(f"browser test: {len(pages(site))} pages in {time.monotonic() - started:.1f} s")


def test_chromium_is_found_where_ci_installs_it():
    """.ci/run installs Debian's chromium before the test command, so CI runs the browser test."""
    ci = (Path(__file__).resolve().parent.parent / ".ci" / "run").read_text()
    assert "apt-get install -y chromium chromium-driver" in ci


def test_runs_declared_on_demand_wait_only_outside_the_engines_default_families(tmp_path):
    """An engine slow beyond its default families (Newton's solvers) runs those families in
    every run, named or not; its other runs wait for --on-demand."""
    fakes = Path(__file__).parent / "fakes.py"
    cases = ["central_impact[e=0.5,m=1:1]", "slide_to_stop[mu=0.5,v0=2]"]
    for extra, ran in (([], {"central_impact"}), (["--on-demand"], {"central_impact", "slide_to_stop"})):
        out = tmp_path / f"out{len(extra)}"
        assert main(["run", "--adapter", f"{fakes}:CoreOnDemandFake", "--engines", "fake-core", "--cases", *cases,
                     "--quiet", "--out", str(out), *extra]) == 0
        rows = list(csv.DictReader(open(out / "results.csv")))
        assert {r["case"] for r in rows} == ran


def test_a_run_with_every_job_left_out_writes_an_empty_report(tmp_path):
    """Every job on demand (Newton's runs, say): the run reports nothing to judge instead of
    failing on an empty scorecard."""
    out = tmp_path / "out"
    fakes = Path(__file__).parent / "fakes.py"
    assert main(["run", "--adapter", f"{fakes}:OnDemandFake", "--engines", "fake-slow", "--cases",
                 "central_impact[e=0.5,m=1:1]", "--quiet", "--out", str(out)]) == 0
    assert (out / "report.html").is_file() and "0 checks" in (out / "report.md").read_text()
