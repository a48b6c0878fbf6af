"""Every CUDA kernel a case launches compiles for a real GPU (PTX for sm_90, the H100/H200),
with no GPU: the simulator tests run the kernels' Python source, which accepts code the CUDA
compiler refuses (the periodic walk did not compile for a GPU until this test)."""
import os
import subprocess
import sys

import pytest

pytest.importorskip("numba.cuda")

SCRIPT = r"""
import json, sys
from wcsph.validation import ptx
from wcsph.case.config import load
why = ptx.available()
if why:
    print(json.dumps({"unavailable": why}))
    sys.exit(0)
name, dp, extra = sys.argv[1], float(sys.argv[2]), json.loads(sys.argv[3])
case = load(name, [("dp", dp), ("output.vtk", False), ("output.progress", False)] + list(extra.items()))
done = ptx.compile_case(case, (9, 0))
print(json.dumps({"kernels": [n for n, _, _ in done], "chars": [c for _, _, c in done]}))
"""

#: the shipped cases, coarse; the ones in the default suite cover the plain and the periodic
#: walk, 2D and 3D, both models and float32 and float64
CASES = [
    ("couette_2d", 5e-5, {}, False),  # periodic walk, moving wall, float64
    ("dam_break_3d_bi", 0.06, {}, False),  # 3D WCSPH-BI, float32
    ("dam_break_2d", 0.1, {}, True),
    ("dam_break_3d", 0.06, {}, True),
    ("dam_break_2d_bi", 0.05, {"precision": "float64"}, True),
    ("spheric2_3d", 0.1, {}, True),
    ("hydrostatic_2d", 0.05, {}, True),
    ("hydrostatic_2d_bi", 0.1, {}, True),
    ("poiseuille_2d", 5e-5, {}, True),
    ("poiseuille_open_2d", 0.05, {}, True),
    ("taylor_green_2d", 0.05, {}, True),
    ("moving_square_2d", 0.1, {}, True),
    ("floating_box_2d", 0.05, {}, True),
    ("cylinder_entry_2d", 0.2, {}, True),
    ("wave_flume_2d", 0.05, {}, True),
    ("dam_break_2d_bi", 0.05, {"model.kernel_correction": "CSPM", "model.collision": "DPC",
                              "model.shifting": "DeltaPlus", "model.xsph": "position",
                              "model.pressure": "Monaghan1992ArtificialViscosity"}, True),
    ("floating_box_waves_3d", 0.08, {}, True),
    ("dam_break_2d", 0.1, {"model.kernel_correction": "CSPM", "model.shifting": "Lind",
                           "model.density": "continuity", "model.DiffusiveTerm": "MolteniDiffusiveTerm"}, True),
]


@pytest.mark.parametrize("name,dp,extra", [
    pytest.param(name, dp, extra, id=f"{name}-{k}", marks=[pytest.mark.validation] if slow else [])
    for k, (name, dp, extra, slow) in enumerate(CASES)])
def test_every_kernel_compiles_to_ptx(name, dp, extra):
    import json

    env = {k: v for k, v in os.environ.items() if k != "NUMBA_ENABLE_CUDASIM"}
    r = subprocess.run([sys.executable, "-c", SCRIPT, name, str(dp), json.dumps(extra)], capture_output=True, text=True,
                       env=env, timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    res = json.loads(r.stdout.strip().splitlines()[-1])
    if "unavailable" in res:
        if sys.platform.startswith("linux"):  # the test extra installs NVVM and NVRTC there
            pytest.fail(f"no CUDA compiler: {res['unavailable']}")
        pytest.skip(res["unavailable"])
    kernels = res["kernels"]
    assert any(k.startswith("pass") for k in kernels) and any(k.startswith("map") for k in kernels), kernels
    assert "_check_blocks" in kernels and "_scan_chunks" in kernels
    assert any(k.startswith("size") for k in kernels) and any(k.startswith("scan+size") for k in kernels), kernels
    assert min(res["chars"]) > 1000  # a kernel's PTX, not an empty module
