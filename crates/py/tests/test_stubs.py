"""The type stubs describe the module that is really installed."""

import ast
import inspect
import pathlib

import fs020n
from fs020n import _fs020n

STUB = pathlib.Path(fs020n.__file__).with_name("_fs020n.pyi")
TYPING_ONLY = {"Six", "Rows", "Pose", "RttStats", "RobotStats", "ServoStats"}


def stub_tree():
    return ast.parse(STUB.read_text())


def test_the_stub_and_py_typed_are_installed():
    assert STUB.is_file()
    assert STUB.with_name("py.typed").is_file()


def test_every_stubbed_name_exists_and_every_public_name_is_stubbed():
    tree = stub_tree()
    stubbed = {}
    for node in tree.body:
        if isinstance(node, ast.ClassDef):
            members = set()
            for item in node.body:
                if isinstance(item, ast.FunctionDef):
                    members.add(item.name)
                elif isinstance(item, ast.AnnAssign) and isinstance(item.target, ast.Name):
                    members.add(item.target.id)
            stubbed[node.name] = members
        elif isinstance(node, ast.FunctionDef):
            stubbed[node.name] = None
        elif isinstance(node, ast.AnnAssign):
            stubbed[node.target.id] = None
        elif isinstance(node, ast.Assign):
            for t in node.targets:
                stubbed[t.id] = None
    runtime = {n for n in dir(_fs020n) if not n.startswith("_") or n == "__version__"}
    assert runtime == (set(stubbed) - TYPING_ONLY), "stub and module differ"
    for name, members in stubbed.items():
        if members is None or name in TYPING_ONLY:
            continue
        cls = getattr(_fs020n, name)
        public = {m for m in dir(cls) if not m.startswith("_")}
        stubbed_public = {m for m in members if not m.startswith("_")}
        assert public == stubbed_public, f"{name}: runtime {public ^ stubbed_public} differ"
        if "__enter__" in dir(cls) and name != "Status":
            assert "__enter__" in members and "__exit__" in members, name


def test_signatures_in_the_stub_match_the_runtime_for_keyword_names():
    tree = stub_tree()
    for node in tree.body:
        if not isinstance(node, ast.ClassDef):
            continue
        cls = getattr(_fs020n, node.name, None)
        for item in node.body:
            if not isinstance(item, ast.FunctionDef) or item.name.startswith("__"):
                continue
            if any(isinstance(d, ast.Name) and d.id == "property" for d in item.decorator_list):
                continue
            fn = getattr(cls, item.name)
            try:
                sig = inspect.signature(fn)
            except (TypeError, ValueError):
                continue
            stub_args = [a.arg for a in item.args.args + item.args.kwonlyargs if a.arg != "self"]
            run_args = [p for p in sig.parameters if p != "self"]
            run_args = [p for p in run_args if sig.parameters[p].kind not in (
                inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)]
            assert stub_args == run_args, f"{node.name}.{item.name}: {stub_args} vs {run_args}"


def test_help_is_useful():
    doc = fs020n.Robot.__doc__
    assert "KeyboardInterrupt" in doc and "LinkLostError" in doc
    for name in ["move_joints", "stream", "servo", "preflight", "close"]:
        assert getattr(fs020n.Robot, name).__doc__, name
    assert "free port" in fs020n.Emulator.__doc__
    assert "mm" in fs020n.fk.__doc__
