"""The package's face: docstrings, help(), type stubs that mypy accepts."""

import inspect
import pydoc
import subprocess
import sys
from pathlib import Path

import pytest

import cliff_lhmp

PUBLIC = [name for name in cliff_lhmp.__all__]


def test_everything_public_has_a_docstring():
    for name in PUBLIC:
        obj = getattr(cliff_lhmp, name)
        if isinstance(obj, bool):  # a flag (HAS_ZENOH): the package docstring explains it
            assert name in (cliff_lhmp.__doc__ or ""), name
            continue
        assert obj.__doc__ and len(obj.__doc__.strip()) > 40, name
        if inspect.isclass(obj) and not issubclass(obj, BaseException):
            for attr, member in vars(obj).items():
                if attr.startswith("_"):
                    continue
                assert member.__doc__, f"{name}.{attr} has no docstring"


def test_help_of_predict_teaches():
    text = pydoc.render_doc(cliff_lhmp.predict, renderer=pydoc.plaintext)
    for needle in ("histories", "(t, x, y)", "(t, x, y, speed, heading)", "positions",
                   "lengths", "NaN", "seed", "Example", "k=20", "dt=0.4"):
        assert needle in text, needle
    sig = inspect.signature(cliff_lhmp.predict)
    assert sig.parameters["k"].kind is inspect.Parameter.KEYWORD_ONLY
    assert sig.parameters["k"].default == 20


def test_classes_report_the_package_as_module():
    for name in ("Map", "Prediction", "Client", "Evaluation", "OnlineMap", "Rejected"):
        assert getattr(cliff_lhmp, name).__module__.startswith("cliff_lhmp"), name


def test_stubs_and_py_typed_are_installed():
    pkg = Path(cliff_lhmp.__file__).parent
    assert (pkg / "py.typed").exists()
    assert (pkg / "__init__.pyi").exists()


def test_stubs_cover_the_public_api():
    stub = (Path(cliff_lhmp.__file__).parent / "__init__.pyi").read_text()
    for name in PUBLIC:
        assert name in stub, name
    assert "__version__" in stub
    assert isinstance(cliff_lhmp.__version__, str) and cliff_lhmp.__version__[0].isdigit()


def test_mypy_accepts_a_typed_program():
    pytest.importorskip("mypy")
    example = Path(__file__).with_name("typed_usage.py")
    out = subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--no-incremental", str(example)],
        capture_output=True, text=True, cwd=Path(__file__).parent,
    )
    assert out.returncode == 0, out.stdout + out.stderr


def test_mypy_rejects_a_wrong_call():
    pytest.importorskip("mypy")
    out = subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--no-incremental", "-c",
         "import cliff_lhmp\ncliff_lhmp.predict(cliff_lhmp.Map.demo(), [], k='many')\n"
         "cliff_lhmp.Client.connect_zenoh(7447, deadline=1.0)\n"],
        capture_output=True, text=True,
    )
    assert out.returncode != 0 and "k" in out.stdout, out.stdout
    assert '"connect_zenoh" of "Client" has incompatible type "int"' in out.stdout, out.stdout
