#!/usr/bin/env bash
# The test command (README, "Two commands"; CI runs it through .ci/run).
#
#   bash tests/run.sh            the fast tier (everything not marked slow)
#   bash tests/run.sh --slow     the slow tier only (tests marked @pytest.mark.slow)
#
# Further arguments go to pytest.  Installs the system tools the tests need
# from Debian when they are missing and it may (root, or sudo without a
# password), then the project with its test, sweep and docs extras (tests/sweep/test_sweep.py runs
# sweeps on a local Dask cluster; tests/system/test_docs.py builds docs/ with Sphinx), then runs pytest on every
# core (pytest-xdist).  A missing tool is an error (exit 2), never a skip.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

tier=(-m "not slow")
if [[ "${1:-}" == "--slow" ]]; then
  tier=(-m slow)
  shift
fi

# clang and gcc/g++: the generated C is compiled with each of them (make: examples/c);
# libclang-rt-dev: clang's sanitizer runtimes (MemorySanitizer runs the generated C);
# pdflatex: `derive latex --pdf` compiles the report;
# pdftoppm, pdftotext: the PDF pages are rendered and their text checked.
# lmodern: the Latin Modern T1 fonts (vector, with ligatures), without which pdflatex falls
# back to bitmap fonts whose text does not extract cleanly.
PACKAGES=(clang libclang-rt-dev texlive-latex-base texlive-latex-recommended texlive-fonts-recommended lmodern poppler-utils)
missing_tools() {
  missing=()
  for tool in clang pdflatex pdftoppm pdftotext g++; do
    command -v "$tool" >/dev/null 2>&1 || missing+=("$tool")
  done
  if command -v kpsewhich >/dev/null 2>&1 && [[ -z "$(kpsewhich lmodern.sty 2>/dev/null)" ]]; then
    missing+=("lmodern.sty")
  fi
  if command -v clang >/dev/null 2>&1 && ! echo 'int main(void){return 0;}' |
      clang -fsanitize=memory -x c - -o /dev/null >/dev/null 2>&1; then
    missing+=("msan-runtime")
  fi
  command -v cc >/dev/null 2>&1 || command -v gcc >/dev/null 2>&1 || missing+=("cc")
  command -v make >/dev/null 2>&1 || missing+=("make")
}
missing_tools
if [[ " ${missing[*]} " == *" cc "* || " ${missing[*]} " == *" g++ "* ]]; then
  PACKAGES+=(gcc g++)
fi
if [[ " ${missing[*]} " == *" make "* ]]; then
  PACKAGES+=(make)
fi

if ((${#missing[@]})); then
  sudo=()
  if [[ "$(id -u)" != 0 ]] && command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then
    sudo=(sudo -n)
  fi
  if command -v apt-get >/dev/null 2>&1 && { [[ "$(id -u)" == 0 ]] || ((${#sudo[@]})); }; then
    echo "tests/run.sh: installing ${PACKAGES[*]} from Debian (missing: ${missing[*]}; the tests compile the generated C with gcc, clang and g++, compile the LaTeX report and check its PDF)"
    "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update -qq
    "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
      "${PACKAGES[@]}" >/dev/null
    missing_tools
  fi
  if ((${#missing[@]})); then
    echo "tests/run.sh: missing ${missing[*]}; install the Debian packages ${PACKAGES[*]} (e.g. as root: apt-get install ${PACKAGES[*]})" >&2
    exit 2
  fi
fi

# A system Python that pip may not install into (Debian's python3: PEP 668's
# EXTERNALLY-MANAGED marker), or one without pip, gets a venv of the project's own
# in .venv/ (Debian's python3-venv, installed like the tools above when missing).
PY=python3
if ! python3 -m pip --version >/dev/null 2>&1 || python3 - <<'PYEOF'
import os, sys, sysconfig
managed = os.path.exists(os.path.join(sysconfig.get_paths()["stdlib"], "EXTERNALLY-MANAGED"))
sys.exit(0 if managed and sys.prefix == sys.base_prefix else 1)
PYEOF
then
  if [[ ! -x .venv/bin/python ]]; then
    if ! python3 -m venv .venv >/dev/null 2>&1; then
      rm -rf .venv
      echo "tests/run.sh: installing python3-venv from Debian (this python3 cannot make a venv for the test extra)"
      env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends python3-venv >/dev/null
      python3 -m venv .venv
    fi
  fi
  PY=.venv/bin/python
fi

export PIP_ROOT_USER_ACTION=ignore
"$PY" -m pip install -q -e '.[test,sweep,docs]'
# --dist loadgroup: the files marked xdist_group (each shares one long cold build) run on
# one worker each, sent out first; every other test is handed out alone, as with --dist load.
exec "$PY" -m pytest -q -n auto --dist loadgroup "${tier[@]}" "$@"
