"""The type stubs match the extension: every public name of robosim._robosim and of each of
its classes is declared in _robosim.pyi, and every name the stubs declare exists."""

import ast
import os

import robosim
from robosim import _robosim

STUBS = os.path.join(os.path.dirname(robosim.__file__), "_robosim.pyi")
PKG_STUBS = os.path.join(os.path.dirname(robosim.__file__), "__init__.pyi")


def public(names):
    return {n for n in names if not n.startswith("_")}


def stub_tree(path):
    with open(path) as f:
        return ast.parse(f.read())


def stub_classes(tree):
    """{class name: set of its member names} from a stub module."""
    out = {}
    for node in tree.body:
        if isinstance(node, ast.ClassDef):
            members = set()
            for item in node.body:
                if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    members.add(item.name)
                elif isinstance(item, ast.AnnAssign) and isinstance(item.target, ast.Name):
                    members.add(item.target.id)
                elif isinstance(item, ast.Assign):
                    members.update(t.id for t in item.targets if isinstance(t, ast.Name))
            out[node.name] = public(members)
    return out


def test_every_class_of_the_module_is_stubbed_and_back():
    classes = stub_classes(stub_tree(STUBS))
    module = {n for n in public(dir(_robosim)) if isinstance(getattr(_robosim, n), type)}
    assert module == set(classes), f"in the module only: {module - set(classes)}; in the stubs only: {set(classes) - module}"


def test_every_member_of_every_class_is_stubbed_and_back():
    base = public(dir(Exception))
    # An exception's `kind` and `message` are set on each instance: look at a real one.
    try:
        robosim.Session("no_such_session_for_the_stub_test")
    except robosim.SessionError as e:
        raised = public(dir(e))
    else:
        raise AssertionError("attaching to a missing session did not raise")
    for name, members in stub_classes(stub_tree(STUBS)).items():
        cls = getattr(_robosim, name)
        if issubclass(cls, BaseException):
            own = public(dir(cls)) - base
            assert own <= members, f"{name}: not in the stubs: {sorted(own - members)}"
            assert members <= raised, f"{name}: stubbed but absent: {sorted(members - raised)}"
            continue
        actual = public(dir(cls))
        assert actual == members, (
            f"{name}: in the module only {sorted(actual - members)}; in the stubs only {sorted(members - actual)}"
        )


def test_the_package_stub_exports_what_the_package_does():
    tree = stub_tree(PKG_STUBS)
    names = set()
    for node in tree.body:
        if isinstance(node, ast.ImportFrom):
            names.update(a.asname or a.name for a in node.names)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.add(node.target.id)
    assert set(robosim.__all__) | {"__version__"} == names
