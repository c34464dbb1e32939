"""What the scene tests share: the example scene's text and `derive run` of a scene text."""
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DEFAULT = (ROOT / "scenes" / "default.toml").read_text()


def run_scene(tmp_path: Path, text: str, *flags):
    """`derive run` of scene `text` (written to tmp_path/scene.toml), outputs in tmp_path/out."""
    scene = tmp_path / "scene.toml"
    scene.write_text(text)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "derive", "run", str(scene), "--output-dir",
                           str(tmp_path / "out"), *flags], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=900)
