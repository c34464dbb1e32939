"""What the scene tests share: the example scene's text and `derive run` of a scene text."""
from pathlib import Path

from tests.in_process import derive_cli

ROOT = Path(__file__).resolve().parents[2]
DEFAULT = (ROOT / "scenes" / "default.toml").read_text()


def run_scene(tmp_path: Path, text: str, *flags):
    """`derive run` of scene `text` (written to tmp_path/scene.toml), outputs in tmp_path/out.

    In this process (tests/in_process.py): what the run prints and returns is checked here,
    the process around it in tests/system/test_cli_errors.py."""
    scene = tmp_path / "scene.toml"
    scene.write_text(text)
    return derive_cli("run", scene, "--output-dir", tmp_path / "out", *flags, cwd=tmp_path)
