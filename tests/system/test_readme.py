"""The README's promises stay true: its errata table is the recorded errata."""
from pathlib import Path

from derive.verification.errata import errata_markdown

README = (Path(__file__).resolve().parents[2] / "README.md").read_text()


def test_readme_errata_table_is_current():
    assert errata_markdown().strip() in README


def test_readme_states_the_two_commands():
    assert "python3 -m pip install -q -e . && python3 -m derive all" in README
    assert "# the tests\nbash tests/run.sh\n" in README
