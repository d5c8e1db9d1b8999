#!/usr/bin/env bash
# Set up mitsar on a Debian machine: system LLVM for Dr.Jit, a virtual environment, the package.
# Idempotent: a second run only checks. Usage: bash scripts/setup.sh [VENV_DIR]
set -euo pipefail
venv="${1:-.venv}"
python="${PYTHON:-python3}"

as_root() { if [ "$(id -u)" = 0 ]; then "$@"; elif command -v sudo >/dev/null; then sudo "$@"; else
  echo "setup: need root to run: $*" >&2; return 1; fi; }

# 1. Dr.Jit's CPU backend needs libLLVM >= 16 (Debian 12's default 15 crashes on dr.maximum).
have_llvm() { ldconfig -p 2>/dev/null | grep -Eq 'libLLVM(-|\.so\.)(1[6-9]|[2-9][0-9])'; }
if ! have_llvm && [ -z "${DRJIT_LIBLLVM_PATH:-}" ]; then
  if command -v apt-get >/dev/null; then
    echo "setup: installing libllvm19 (Dr.Jit needs LLVM >= 16)"
    as_root apt-get update -qq
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libllvm19 >/dev/null
  else
    echo "setup: no libLLVM >= 16 found and no apt-get: install LLVM >= 16 and set" \
         "DRJIT_LIBLLVM_PATH to its libLLVM.so" >&2
    exit 1
  fi
fi

# 1b. A headless browser for the report tests (tests/test_report.py): Debian's
#     chromium-headless-shell; without one those tests skip with the reason.
if ! command -v chromium-headless-shell >/dev/null && ! command -v chromium >/dev/null; then
  if command -v apt-get >/dev/null; then
    echo "setup: installing chromium-headless-shell (renders the HTML reports in the tests)"
    { as_root apt-get update -qq && as_root env DEBIAN_FRONTEND=noninteractive \
        apt-get install -y -qq chromium-headless-shell >/dev/null; } \
      || echo "setup: no headless browser (the report rendering tests will skip)" >&2
  fi
fi

# 2. A virtual environment (Debian's python3 needs python3-venv for it).
if [ ! -x "$venv/bin/python" ]; then
  if ! "$python" -m venv "$venv" 2>/dev/null; then
    echo "setup: installing python3-venv"
    as_root apt-get update -qq
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv >/dev/null
    rm -rf "$venv"
    "$python" -m venv "$venv"
  fi
fi

# 3. The package and its dependencies (only when pyproject.toml changed).
stamp="$venv/.mitsar-installed"
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ]; then
  "$venv/bin/python" -m pip install -q --upgrade pip
  "$venv/bin/python" -m pip install -q -e ".[test,docs]"   # docs: make docs, tests/test_docs_site.py
  touch "$stamp"
fi

# 4. Fail now, with the fix, if the LLVM backend does not work.
"$venv/bin/python" -c "from mitsar.backend import require_llvm; require_llvm()"
echo "setup: ok ($("$venv/bin/python" -c 'import mitsuba, drjit; print("mitsuba", mitsuba.__version__, "drjit", drjit.__version__)'))"
