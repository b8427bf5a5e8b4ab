"""`rapidc verify --html` and `rapidc report --html`: the verify report as one self-contained HTML
page, made from a real tiny verify run, checked as text and in a real headless browser."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import imageio.v2 as imageio
import numpy as np
import pytest

from rapid_dsl.cli import main

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "examples" / "scenes" / "push_box.yaml"
SMALL = ("--samples", "8", "--iterations", "2")

# Untrusted text in a goal and a comment; the 1 mm bound on the success clause fails on purpose.
HOSTILE = """\
use stdlib.push

# <img src=x onerror="alert(2)">
strategy shove_box {
  goal "Push <script>alert(1)</script> the box & co 5 cm away"
  roles { box: Object, table: Surface, hand: Manipulator }
  requires { on(box, table) }
  phase shove: push(target=box, support=table, hand=hand) { displacement = [5cm, 0cm, 0cm] }
  success { distance(box, hand) < 1mm }
}
"""


def _has_gl() -> bool:
    from rapid_dsl.runtime.gl import RenderError, start_rendering

    try:
        start_rendering()
    except RenderError:
        return False
    return True


@pytest.fixture(scope="module")
def page(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A real verify run on the scene and 2 variants, with key frames when GL can render (else
    stand-in strips written here, so the page still embeds images)."""
    folder = tmp_path_factory.mktemp("html")
    program = folder / "hostile.rapid"
    program.write_text(HOSTILE, encoding="utf-8")
    media, report, html = folder / "media", folder / "report.json", folder / "page.html"
    gl = _has_gl()
    code = main(["verify", str(program), "--scene", str(SCENE), "--variants", "2", *SMALL,
                 "--report", str(report), "--html", str(html), "--quiet",
                 *(["--media", str(media)] if gl else [])])
    assert code == 1   # the 1 mm clause fails
    if not gl:
        media.mkdir()
        for name in ("scene.png", "variant-0000.png", "variant-0001.png"):
            imageio.imwrite(media / name, np.full((24, 96, 3), 128, dtype=np.uint8))
        assert main(["report", str(report), "--html", str(html), "--media", str(media)]) == 0
    return {"program": program, "media": media, "report": report, "html": html}


@pytest.mark.slow
def test_the_page_holds_rate_failures_plots_frames_and_the_escaped_program(page):
    text = page["html"].read_text(encoding="utf-8")
    report = json.loads(page["report"].read_text())
    assert "success rate 0.0%" in text and report["summary"]["success_rate"] == 0
    assert "distance(box, hand) &lt; 1mm" in text        # the failing clause, escaped
    assert text.count("<svg") == 1 and "<polyline" in text  # phase `shove`'s cost curves
    assert text.count('src="data:image/png;base64,') == 3  # a strip per run
    assert "<script" not in text and "onerror=" not in text.replace("onerror=&#34;", "")
    assert "Push &lt;script&gt;alert(1)&lt;/script&gt; the box &amp; co" in text
    assert "&lt;img src=x onerror=&#34;alert(2)&#34;&gt;" in text
    assert not re.search(r"(src|href)=\"(https?:|//|file:)", text)   # nothing fetched
    marked = re.findall(r'<div class="marked"><span class="n">(\d+)</span>', text)
    assert "9" in marked and set(marked) <= {"8", "9"}   # the success line (and the phase)
    phase = report["results"][0]["phases"][0]
    assert len(phase["best_cost_per_iteration"]) == 2 == len(phase["mean_cost_per_iteration"])


@pytest.mark.slow
def test_report_renders_the_same_page_again(page, tmp_path: Path):
    again = tmp_path / "again.html"
    code = main(["report", str(page["report"]), "--html", str(again), "--program",
                 str(page["program"]), "--media", str(page["media"])])
    assert code == 0
    assert again.read_text(encoding="utf-8") == page["html"].read_text(encoding="utf-8")


@pytest.mark.slow
def test_without_media_or_program_the_page_says_so(page, tmp_path: Path):
    report = json.loads(page["report"].read_text())
    report["program"] = "/etc/passwd"      # not a program file: its text is not shown
    report["settings"]["media"] = None
    report["results"][0]["phases"][0]["best_cost_per_iteration"] = [None, 1.5]   # not finite
    source, html = tmp_path / "r.json", tmp_path / "p.html"
    source.write_text(json.dumps(report), encoding="utf-8")
    assert main(["report", str(source), "--html", str(html)]) == 0
    text = html.read_text(encoding="utf-8")
    assert "no key frames: verify ran without --media DIR" in text
    assert "the program&#39;s text was not given" in text and "root:" not in text
    assert "data:image" not in text
    assert text.count("<svg") == 1


def test_report_will_not_write_the_page_over_its_report(rapidc, write):
    report = write("r.json", "{}")
    run = rapidc("report", report, "--html", report)
    assert run.code == 2 and "it is one of the inputs" in run.err
    assert report.read_text(encoding="utf-8") == "{}"


def test_a_symlink_a_folder_or_an_input_as_the_page_is_refused_before_running(
        rapidc, write, tmp_path: Path):
    program = write("hostile.rapid", HOSTILE)
    (tmp_path / "elsewhere.html").write_text("kept", encoding="utf-8")
    (tmp_path / "link.html").symlink_to(tmp_path / "elsewhere.html")
    for page, why in ((tmp_path / "link.html", "is a symbolic link"),
                      (tmp_path, "a folder, not a file"),
                      (program, "it is one of the inputs")):
        run = rapidc("verify", program, "--scene", SCENE, "--variants", 1, "--html", page)
        assert run.code == 2 and why in run.err and "verify:" not in run.err
    assert (tmp_path / "elsewhere.html").read_text(encoding="utf-8") == "kept"


@pytest.mark.parametrize("content, why", [
    ("[]", "not a rapidc verify report"),
    ("{", "r.json:1:2: not JSON"),
    ('{"format": "rapidc-verify/1", "summary": {}, "results": [{"phases": [3]}]}',
     "r.json:1:1: $.rapidc: required field is missing (and"),
])
def test_report_refuses_what_is_not_a_report(rapidc, write, tmp_path: Path, content, why):
    run = rapidc("report", write("r.json", content), "--html", tmp_path / "p.html")
    assert run.code == 2 and why in run.err and "Traceback" not in run.err
    assert not (tmp_path / "p.html").exists()


def _chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.mark.slow
def test_the_page_renders_in_a_headless_browser(page, tmp_path: Path):
    browser = _chromium()
    if browser is None:
        if os.environ.get("CI"):
            pytest.fail("chromium is not installed (.ci/run installs it)")
        pytest.skip("chromium is not installed (apt-get install chromium)")
    url = page["html"].resolve().as_uri()
    base = [browser, "--headless", "--no-sandbox", "--disable-gpu", "--window-size=1200,2000",
            f"--user-data-dir={tmp_path / 'profile'}"]
    shot = tmp_path / "shot.png"
    done = subprocess.run([*base, f"--screenshot={shot}", url], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0 and shot.stat().st_size > 10_000, done.stderr
    if os.environ.get("RAPIDC_TEST_ARTIFACTS"):
        artifacts = Path(os.environ["RAPIDC_TEST_ARTIFACTS"])
        artifacts.mkdir(parents=True, exist_ok=True)
        shutil.copy(shot, artifacts / "verify_report.png")
    dom = subprocess.run([*base, "--dump-dom", url], capture_output=True, text=True,
                         timeout=120).stdout
    assert "success rate 0.0%" in dom
    assert "distance(box, hand) &lt; 1mm" in dom
    assert re.search(r"<svg[^>]*>.*<polyline", dom, re.S)
    assert re.search(r'<img src="data:image/png;base64,[A-Za-z0-9+/=]{100}', dom)
    assert "Push &lt;script&gt;alert(1)&lt;/script&gt; the box &amp; co" in dom
    assert "<script" not in dom   # the goal stayed text: no element was made from it
    image = imageio.imread(shot)
    assert image.shape[:2] == (2000, 1200) and image.std() > 10
