"""Campaigns on Dask distributed (a local cluster of two worker processes), and what a CI
and a person read of them: JUnit XML, and the HTML report opened in a real browser
(Debian's chromium, driven by Selenium through Debian's chromedriver)."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import pyarrow.dataset as pds
import pytest

from vehil import campaign, scenario, sweep

VEHIL = [sys.executable, "-m", "vehil"]


@pytest.fixture(scope="module")
def short_sines(built, tmp_path_factory, write_short_sines):  # noqa: ANN001, ANN201
    """Three 1-s sines (one of them held to a truth bound its noise cannot meet), and a
    baseline: an earlier run of one of them."""
    folder = tmp_path_factory.mktemp("campaign")
    write_short_sines(folder)
    base = folder / "base"
    argv = [*VEHIL, "run", str(folder / "sine-a.toml"), "--board", "native", "--out", str(base)]
    subprocess.run(argv, check=True, capture_output=True)
    out = folder / "out"
    argv = [*VEHIL, "run", str(folder / "sine-*.toml"), "--board", "native", "--dask"]
    argv += ["--workers", "2", "--out", str(out), "--json", "--junit", str(out / "junit.xml")]
    argv += ["--html", str(out / "report.html"), "--baseline", str(base / "figures.json")]
    proc = subprocess.run(argv, capture_output=True, text=True)
    return out, proc


def test_scenarios_on_dask_give_one_table_one_dataset_and_the_worst_status(short_sines) -> None:  # noqa: ANN001
    out, proc = short_sines
    assert proc.returncode == 1, proc.stderr  # FAIL is the worst of PASS, PASS, FAIL
    rows = {r["scenario"]: r["verdict"] for r in json.loads(proc.stdout)}
    assert rows == {"sine-a": "PASS", "sine-b": "PASS", "sine-noisy": "FAIL"}
    table = pds.dataset(out / "results").to_table().to_pylist()
    assert sorted(r["name"] for r in table) == ["sine-a", "sine-b", "sine-noisy"]
    assert all(r["samples"] == 500 and r["outputs.y.truth.rmse"] > 0.03 for r in table)
    assert all((out / name / "report.md").exists() for name in rows)


def test_junit_has_a_case_per_scenario_with_its_figures(short_sines) -> None:  # noqa: ANN001
    out, _ = short_sines
    suite = ET.parse(out / "junit.xml").getroot().find("testsuite")
    assert suite is not None and (suite.get("tests"), suite.get("failures")) == ("3", "1")
    cases = {c.get("name"): c for c in suite.iter("testcase")}
    failure = cases["sine-noisy"].find("failure")
    assert failure is not None and "y (truth)" in (failure.get("message") or "")
    props = {p.get("name"): p.get("value") for p in cases["sine-a"].iter("property")}
    assert props["verdict"] == "PASS" and props["samples"] == "500"
    assert float(props["outputs.y.truth.rmse"]) < 0.06


def test_the_html_report_shows_verdicts_trend_and_plots_in_a_browser(short_sines) -> None:  # noqa: ANN001
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.by import By

    out, _ = short_sines
    page = out / "report.html"
    assert 'src="data:image/png;base64,' in page.read_text()  # one file, nothing beside it
    options = Options()
    options.binary_location = "/usr/bin/chromium"
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1280,1600"):
        options.add_argument(arg)
    browser = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=options)
    try:
        browser.get(page.as_uri())
        verdicts = browser.find_elements(By.CSS_SELECTOR, "#verdicts tbody tr")
        words = {
            r.find_elements(By.TAG_NAME, "td")[0].text: r.find_elements(By.TAG_NAME, "td")[1].text
            for r in verdicts
        }
        assert words == {"sine-a": "PASS", "sine-b": "PASS", "sine-noisy": "FAIL"}
        trend = browser.find_elements(By.CSS_SELECTOR, "#trend tbody tr")
        assert trend and all(r.text.startswith("sine-a") for r in trend)  # the baseline's one
        plots = browser.find_elements(By.CSS_SELECTOR, "img.plot")
        assert len(plots) >= 3 * 2  # each run: y, cycles and latency plots
        assert all(
            browser.execute_script("return arguments[0].naturalWidth", p) > 100 for p in plots
        )
        shot = Path(os.environ.get("VEHIL_SCREENSHOT", out / "report.png"))
        assert browser.save_screenshot(str(shot)) and shot.stat().st_size > 10_000
    finally:
        browser.quit()


def test_a_sweep_on_dask_is_the_sweep_run_here(built) -> None:  # noqa: ANN001
    sc = scenario.load("uiiekf3-abs-dry")
    found = sweep.perturbations(sc, {"i_w": {"lo": 1.0, "hi": 1.5}})
    here = sweep.run(sc, found, 3, "native")
    with campaign.cluster(workers=2) as client:
        there = sweep.run(sc, found, 3, "native", client=client)
    for a, b in zip((here.nominal, *here.drives), (there.nominal, *there.drives), strict=True):
        assert a.drawn == b.drawn and a.figures.outputs == b.figures.outputs
        assert a.figures.verdict == b.figures.verdict
    rows = pds.dataset(there.out / "results").to_table().to_pylist()
    assert [r["drawn.i_w"] for r in rows[1:]] == [d.drawn["i_w"] for d in there.drives]


@pytest.fixture()
def running_scheduler(tmp_path):  # noqa: ANN001, ANN201
    """A Dask cluster started the way a user starts one on a lab machine: `dask scheduler`,
    then `dask worker ADDRESS` of two processes, separate programs on loopback."""
    dask = str(Path(sys.executable).with_name("dask"))
    info, log = tmp_path / "scheduler.json", (tmp_path / "cluster.log").open("w")
    argv = [dask, "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard"]
    procs = [subprocess.Popen([*argv, "--scheduler-file", str(info)], stdout=log, stderr=log)]
    try:
        deadline = time.monotonic() + 60
        while not (info.exists() and info.stat().st_size):
            assert procs[0].poll() is None and time.monotonic() < deadline, "no scheduler"
            time.sleep(0.1)
        address = json.loads(info.read_text())["address"]
        argv = [dask, "worker", address, "--nworkers", "2", "--nthreads", "1", "--no-dashboard"]
        procs.append(subprocess.Popen(argv, stdout=log, stderr=log, cwd=tmp_path))
        yield address
    finally:
        for p in reversed(procs):
            p.terminate()
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()
        log.close()


def test_scenarios_run_on_a_running_scheduler_s_workers(  # noqa: ANN001
    built, running_scheduler, tmp_path, write_short_sines
) -> None:
    write_short_sines(tmp_path)
    out = tmp_path / "out"
    argv = [*VEHIL, "run", str(tmp_path / "sine-*.toml"), "--board", "native"]
    argv += ["--scheduler", running_scheduler, "--out", str(out), "--json"]
    cli = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    stdout, stderr = cli.communicate(timeout=300)
    assert cli.returncode == 1, stderr  # sine-noisy fails its truth bound, wherever it ran
    assert f"at {running_scheduler}" in stderr + stdout
    rows = {r["scenario"]: r["verdict"] for r in json.loads(stdout)}
    assert rows == {"sine-a": "PASS", "sine-b": "PASS", "sine-noisy": "FAIL"}
    table = pds.dataset(out / "results").to_table().to_pylist()
    ran_on = {r["worker"].rpartition(":")[2] for r in table}
    assert ran_on and str(cli.pid) not in ran_on  # the workers ran them, not the command
    assert all(r["samples"] == 500 for r in table)


def test_a_scheduler_that_does_not_answer_is_named_with_what_to_do(built) -> None:  # noqa: ANN001
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    argv = [*VEHIL, "run", "sine", "--board", "native", "--scheduler", f"tcp://127.0.0.1:{port}"]
    proc = subprocess.run(argv, capture_output=True, text=True, timeout=120)
    said = " ".join((proc.stdout + proc.stderr).split())
    assert proc.returncode == 2, said
    assert "no Dask scheduler answers there" in said and "start one (`dask scheduler`" in said
