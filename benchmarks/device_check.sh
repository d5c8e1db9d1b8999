#!/usr/bin/env bash
# GPU check of mitsar on a bare machine with an NVIDIA GPU (docs/gpu.md § 4): installs mitsar,
# Mitsuba and Dr.Jit from the wheels carried in $WHEELS (no package registry needed; prepare
# them with `.venv/bin/python benchmarks/device_wheels.py`), runs tests/test_gpu.py and the
# CPU (LLVM) / GPU (CUDA) benchmark (benchmarks/bench_gpu.py), and writes the logs and the
# benchmark's JSON under $OUT. Needs Python >= 3.11 with NumPy, SciPy, Matplotlib, xarray,
# h5py, tqdm and pytest at $PYTHON. Finishes in about 4-6 minutes on one H100/H200 (the time
# limits below stop each step well before 8).
#
#   PYTHONUNBUFFERED=1 bash benchmarks/device_check.sh 2>&1 | tee $OUT/device_check.log
#
# Environment: PYTHON (python3), WHEELS (.whl), SITE (/tmp/site), OUT (/tmp/mitsar-device),
# SCALE (4: benchmark size), TEST_LIMIT / BENCH_LIMIT (seconds, 180 / 200).
set -u
cd "$(dirname "$0")/.."
PYTHON=${PYTHON:-python3}
WHEELS=${WHEELS:-.whl}
SITE=${SITE:-/tmp/site}
OUT=${OUT:-/tmp/mitsar-device}
SCALE=${SCALE:-4}
mkdir -p "$OUT"
start=$SECONDS
stamp() { echo "=== [$((SECONDS - start)) s] $*"; }

stamp "machine"
uname -srm
"$PYTHON" --version
nproc
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>&1 || true
ldconfig -p 2>/dev/null | grep -i "libLLVM" || echo "no libLLVM in the linker cache"
"$PYTHON" -c "import numpy, scipy, xarray, matplotlib, h5py, tqdm, pytest; print('numpy', numpy.__version__, 'scipy', scipy.__version__, 'xarray', xarray.__version__, 'pytest', pytest.__version__)"

stamp "install from $WHEELS into $SITE"
ls -la "$WHEELS"
rm -rf "$SITE"
"$PYTHON" -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
    --target "$SITE" "$WHEELS"/*.whl || { echo "INSTALL FAILED"; exit 1; }
# The installed mitsar, not the tree's: -P keeps the working directory off sys.path.
export PYTHONPATH="$SITE"
export PYTHONDONTWRITEBYTECODE=1
"$PYTHON" -P - <<'EOF'
import drjit as dr, mitsuba as mi, mitsar
from mitsar import backend
print("mitsar", mitsar.__version__, mitsar.__file__)
print("drjit", dr.__version__, "mitsuba", mi.__version__, "variants", mi.variants())
print("CUDA backend:", backend.cuda_available())
ok, detail = backend.llvm_probe()
print("LLVM backend:", ok, detail[-300:])
print("auto backend:", backend.backend_name())
EOF

stamp "tests/test_gpu.py"
timeout "${TEST_LIMIT:-180}" "$PYTHON" -P -m pytest -p no:cacheprovider -q -s -rs \
    tests/test_gpu.py 2>&1 | tee "$OUT/test_gpu.log"
echo "pytest exit: ${PIPESTATUS[0]}"

stamp "benchmarks/bench_gpu.py --scale $SCALE"
# Run as a script: Python puts benchmarks/ (paper_scene) first on sys.path, not the tree.
timeout "${BENCH_LIMIT:-200}" "$PYTHON" benchmarks/bench_gpu.py --scale "$SCALE" \
    --json "$OUT/bench_gpu.json" 2>&1 | tee "$OUT/bench_gpu.log"
echo "benchmark exit: ${PIPESTATUS[0]}"
stamp "done"
