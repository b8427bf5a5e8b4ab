"""`rapidc verify --media DIR`: one PNG strip of key frames per run, written by whichever process
ran it (this one, or pool workers that render with the back end this process chose)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import imageio.v2 as imageio
import pytest

from rapid_dsl.cli import main
from rapid_dsl.runtime.gl import RenderError, start_rendering
from rapid_dsl.runtime.verification.runner import STRIP_FRAMES, STRIP_SIZE

ROOT = Path(__file__).resolve().parents[2]
PUSH = ROOT / "examples" / "push_box.rapid"
SCENE = ROOT / "examples" / "scenes" / "push_box.yaml"


@pytest.fixture(autouse=True)
def offscreen_gl() -> None:
    try:
        start_rendering()
    except RenderError as error:
        pytest.skip(f"no offscreen GL here: {error}")


@pytest.mark.slow
@pytest.mark.parametrize("jobs", ["1", "2"])
def test_every_run_gets_a_strip_of_key_frames(tmp_path: Path, jobs: str):
    media, report = tmp_path / "media", tmp_path / "r.json"
    code = main(["verify", str(PUSH), "--scene", str(SCENE), "--variants", "1", "--samples", "8",
                 "--iterations", "1", "--jobs", jobs, "--media", str(media), "--report",
                 str(report), "--quiet"])
    assert code in (0, 1)
    records = json.loads(report.read_text())["results"]
    assert [r["media"] for r in records] == [str((media / name).resolve())
                                            for name in ("scene.png", "variant-0000.png")]
    width, height = STRIP_SIZE
    for record in records:
        assert "media_error" not in record
        image = imageio.imread(record["media"])
        assert image.shape == (height, width * STRIP_FRAMES, 3)
        assert image.std() > 10   # a rendered scene, not a blank frame


@pytest.mark.slow
def test_a_fresh_process_renders_too(tmp_path: Path):
    """Regression: verify imported mujoco (without GL) before it asked for rendering."""
    media = tmp_path / "media"
    done = subprocess.run([sys.executable, "-m", "rapid_dsl", "verify", str(PUSH), "--scene",
                           str(SCENE), "--variants", "1", "--samples", "8", "--iterations", "1",
                           "--media", str(media), "--quiet"],
                          capture_output=True, text=True, timeout=300,
                          env={**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")})
    assert done.returncode in (0, 1), done.stderr
    assert sorted(p.name for p in media.iterdir()) == ["scene.png", "variant-0000.png"]
