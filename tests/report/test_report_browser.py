"""report.html as a person sees it: opened in headless Chromium for a run, a compare, a fit
and a sweep; it renders with no console error and no network request, shows its figures and
the animation, and its traces zoom. Needs the Debian packages chromium and chromium-driver
(.ci/run installs them) and selenium."""

from __future__ import annotations

import json
import shutil
import tempfile
from pathlib import Path

import pytest

from flexlink.cli import main

from ..experiment.synthetic import (
    SINGLE_LINK_MAPPING,
    single_link_measurement,
    single_link_text,
    write_csv,
)

pytestmark = pytest.mark.slow

NETWORK = ("http", "https", "ws", "wss", "ftp")
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-first-run",
         "--disable-dev-shm-usage", "--window-size=1200,900")


@pytest.fixture(scope="module")
def folders(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("reports")
    assert main(["paper", "-o", str(root / "run"), "-q", "--animate"]) == 0
    write_csv(root / "measured.csv", single_link_measurement(262.0, 0.03))
    (root / "arm.toml").write_text(single_link_text() + SINGLE_LINK_MAPPING, encoding="utf-8")
    assert main(["compare", str(root / "arm.toml"), "-o", str(root / "cmp"), "-q"]) == 0
    assert main(["fit", str(root / "arm.toml"), "-o", str(root / "fit"), "-q",
                 "-p", "links[0].EI=100:1000", "--channel", "acc",
                 "--max-simulations", "12"]) == 0
    assert main(["sweep", "--paper", "--grid", "links[0].EI=250,350", "-o",
                 str(root / "sweep.nc"), "--workers", "1", "-q"]) == 0
    assert main(["report", str(root / "sweep.nc"), "--animate"]) == 0
    return {"run": root / "run" / "report.html", "compare": root / "cmp" / "report.html",
            "fit": root / "fit" / "report.html", "sweep": root / "sweep.html"}


@pytest.fixture(scope="module")
def browser():
    webdriver = pytest.importorskip("selenium.webdriver")
    binary = shutil.which("chromium") or shutil.which("chromium-browser")
    driver_path = shutil.which("chromedriver")
    if binary is None or driver_path is None:
        pytest.skip("chromium and chromium-driver are not installed (apt-get install -y "
                    "chromium chromium-driver)")
    profile = tempfile.mkdtemp(prefix="flexlink-chromium-")
    options = webdriver.ChromeOptions()
    options.binary_location = binary
    for flag in FLAGS:
        options.add_argument(flag)
    options.add_argument(f"--user-data-dir={profile}")
    options.set_capability("goog:loggingPrefs", {"browser": "ALL", "performance": "ALL"})
    driver = webdriver.Chrome(service=webdriver.ChromeService(executable_path=driver_path),
                              options=options)
    try:
        yield driver
    finally:
        driver.quit()
        shutil.rmtree(profile, ignore_errors=True)


def _requests(driver) -> list[str]:
    urls = []
    for entry in driver.get_log("performance"):
        message = json.loads(entry["message"])["message"]
        if message["method"] == "Network.requestWillBeSent":
            urls.append(message["params"]["request"]["url"])
    return urls


@pytest.mark.parametrize("kind", ["run", "compare", "fit", "sweep"])
def test_report_renders_offline_with_its_figures(folders, browser, kind: str) -> None:
    page = folders[kind]
    browser.get_log("browser"), browser.get_log("performance")  # start clean
    browser.get(page.as_uri())
    assert browser.execute_script("return document.readyState") == "complete"
    errors = [e for e in browser.get_log("browser") if e["level"] in ("SEVERE", "WARNING")]
    assert errors == [], errors
    # the page itself is file://, its images data:; chrome:// is the browser's own UI
    outside = [u for u in _requests(browser) if u.split(":", 1)[0] in NETWORK]
    assert outside == [], outside
    assert browser.title.startswith(("flexlink", "Comparison", "Fit"))
    images = browser.execute_script(
        "return Array.from(document.images).map(i => [i.alt, i.complete, i.naturalWidth])")
    expected = {"run": {"animation", "joint_angles", "sensors", "tip_paths"},
                "compare": {"overlay", "spectra"}, "fit": {"overlay", "spectra"},
                "sweep": {"sweep_animation"}}[kind]
    assert {alt for alt, _, _ in images} == expected
    assert all(done and width > 100 for _, done, width in images), images
    # every trace drew its lines; zooming on time redraws them over the chosen range
    counts = browser.execute_script(
        "return Array.from(document.querySelectorAll('.trace')).map("
        "d => d.querySelectorAll('polyline.series').length)")
    assert counts and all(c >= 1 for c in counts)
    before, after = browser.execute_script(
        "var d = document.querySelector('.trace'); var p = () => d.querySelector("
        "'polyline.series').getAttribute('points').split(' ').length; var a = p();"
        "var t = JSON.parse(d.getAttribute('data-trace')).t;"
        "d.zoom(t[0], t[0] + (t[t.length - 1] - t[0]) / 10); return [a, p()];")
    assert 0 < after < before
    if kind == "fit":
        assert "95 % interval" in browser.page_source
    if kind in ("compare", "fit"):
        assert "nrmse" in browser.page_source
