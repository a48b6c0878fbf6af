"""The structure the docs describe, checked: no import cycle, no module importing a layer
above its own, and "a new term is one file plus its entry" (docs/architecture.md's worked
example, run as printed)."""
import ast
import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "wcsph"
DOC = Path(__file__).resolve().parents[1] / "docs" / "architecture.md"

#: the layers of the package, lowest first: a module may import from its own layer and below;
#: a layer is a top-level module or package (the package is the layer of all its modules)
LAYERS = [
    {"errors", "version"},
    {"backends"},  # compiled loops, particle sets, cell grid, threads, Numba's cache
    {"physics"},  # registry and slots, kernels, terms, integrators
    {"io"},  # readers, formulas, VTK, probes, grids, surface, plots
    {"boundaries"},  # motion, floating bodies, open boundaries
    {"case"},  # the case file and its geometry
    {"models"},
    {"solver"},  # state, stages, loop, MPI, progress
    {"validation", "cli", "__main__", "wcsph"},
]
RANK = {name: k for k, layer in enumerate(LAYERS) for name in layer}


def _modules():
    mods = {}
    for p in SRC.rglob("*.py"):
        parts = p.relative_to(SRC.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        mods[name] = p
    return mods


def _imports(mods):
    """{module: the package modules it imports, at its top or inside a function}."""
    graph = {}
    for name, path in mods.items():
        package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
        deps = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package.split(".")[: len(package.split(".")) - node.level + 1]
                    target = ".".join(base + ([node.module] if node.module else []))
                else:
                    target = node.module or ""
                for a in node.names:
                    deps.add(f"{target}.{a.name}" if f"{target}.{a.name}" in mods else target)
            elif isinstance(node, ast.Import):
                deps.update(a.name for a in node.names)
        graph[name] = {d for d in deps if d in mods and d != name}
    return graph


def _layer(module):
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "wcsph"


def test_every_module_has_a_layer():
    assert {_layer(m) for m in _modules()} <= set(RANK)


def test_no_import_cycle():
    graph = _imports(_modules())
    state = {}

    def visit(m, path):
        state[m] = "open"
        for d in sorted(graph[m]):
            if state.get(d) == "open":
                pytest.fail("import cycle: " + " -> ".join(path[path.index(d):] + [d]))
            if d not in state:
                visit(d, path + [d])
        state[m] = "done"

    for m in sorted(graph):
        if m not in state:
            visit(m, [m])


def test_no_module_imports_a_layer_above_its_own():
    graph = _imports(_modules())
    up = sorted(f"{m} -> {d}" for m, deps in graph.items() for d in deps if RANK[_layer(d)] > RANK[_layer(m)])
    assert not up, "imports from a higher layer:\n" + "\n".join(up)


def _worked_example():
    """The code block of docs/architecture.md whose first line is ``# toy_viscosity.py``."""
    blocks = re.findall(r"```python\n(.*?)```", DOC.read_text(), flags=re.S)
    found = [b for b in blocks if b.startswith("# toy_viscosity.py")]
    assert len(found) == 1, "docs/architecture.md lost its worked example"
    return found[0]


RUN_BOTH = textwrap.dedent("""
    import json, sys
    import numpy as np
    from wcsph import Simulation
    from wcsph.case.config import load
    from wcsph.physics.slots import slot_table

    def final(term, extra):
        case = load("dam_break_2d_bi", [("dp", 0.02), ("time.max_steps", 30), ("model.ViscousTerm", term)] + extra)
        sim = Simulation(case)
        sim.run()
        ids, x, v = sim.host(sim.fluid, "id", "x", "v")
        o = np.argsort(ids)
        return x[:, o], v[:, o], sim.time_step()

    mu = 0.05  # 50 times water's: large enough that the term shows in 30 steps
    ref = final("PhysicalViscosity_MVT", [("model.dynamicViscosity", mu)])
    toy = final("ToyViscosity", [("model.toy_mu", mu)])
    none = final("ToyViscosity", [("model.toy_mu", 0.0)])  # its loops again: no compile
    print(json.dumps({"dx": float(np.abs(ref[0] - toy[0]).max()), "dv": float(np.abs(ref[1] - toy[1]).max()),
                      "dt": [ref[2], toy[2]], "effect": float(np.abs(ref[1] - none[1]).max()),
                      "listed": "ToyViscosity" in slot_table()}))
""")


def test_a_new_term_is_one_file_plus_its_entry(tmp_path):
    """The worked example as a plug-in module: accepted as a case's ViscousTerm, listed in the
    slot table, and the same motion as PhysicalViscosity_MVT with the same viscosity."""
    (tmp_path / "toy_viscosity.py").write_text(_worked_example())
    env = dict(os.environ, WCSPH_PLUGINS="toy_viscosity",
               PYTHONPATH=os.pathsep.join([str(tmp_path), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.run([sys.executable, "-c", RUN_BOTH], capture_output=True, text=True, env=env, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["listed"]
    assert out["effect"] > 1e-6, out  # the viscosity moves the particles: the comparison means something
    assert out["dx"] == 0.0 and out["dv"] == 0.0, out
    assert out["dt"][0] == out["dt"][1], out  # its nu sets the same viscous time-step limit


def test_an_unknown_plugin_module_is_one_line(tmp_path):
    env = dict(os.environ, WCSPH_PLUGINS="no_such_module_here")
    proc = subprocess.run([sys.executable, "-m", "wcsph.cli", "cases"], capture_output=True, text=True, env=env,
                          timeout=300)
    assert proc.returncode != 0
    assert "no_such_module_here" in proc.stderr and "Traceback" not in proc.stderr, proc.stderr[-2000:]


def test_the_tests_mirror_the_packages():
    """tests/<package>/ holds the tests of src/wcsph/<package>/; what spans the whole package
    (this file) stays at the top."""
    tests = Path(__file__).resolve().parent
    dirs = {p.name for p in tests.iterdir() if p.is_dir() and not p.name.startswith((".", "__"))}
    packages = {p.name for p in SRC.iterdir() if (p / "__init__.py").exists()}
    assert dirs and dirs <= packages, sorted(dirs - packages)
    assert not [p.name for p in tests.glob("test_*.py") if p.name != "test_architecture.py"]


def test_no_name_of_the_package_hides_a_subpackage():
    """Every subpackage imports by its dotted name (``import wcsph.solver.loads``), and no name
    that ``wcsph`` exports is also a subpackage's (the function ``wcsph.run`` once hid the
    package ``wcsph.run``)."""
    import importlib

    import wcsph

    subpackages = sorted(p.name for p in SRC.iterdir() if (p / "__init__.py").exists())
    for name in subpackages:
        module = importlib.import_module(f"wcsph.{name}")
        assert getattr(wcsph, name) is module, name
    assert not set(wcsph.__all__) & set(subpackages)
    import wcsph.solver.loads as loads

    assert callable(loads.body_loads) and callable(wcsph.run)
