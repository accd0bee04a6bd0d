"""The type stubs (_native.pyi) match what the binary exports: names, parameters, defaults, kinds."""

from __future__ import annotations

import ast
import inspect
from pathlib import Path

import unicac
from unicac import _native

STUB = Path(unicac.__file__).with_name("_native.pyi")


def _stub_tree() -> ast.Module:
    return ast.parse(STUB.read_text())


def _params(node: ast.FunctionDef, skip_self: bool) -> list[tuple[str, str | None]]:
    """(name, default source) per parameter, as the stub declares them."""
    args = node.args.args[1:] if skip_self else node.args.args
    defaults = [None] * (len(args) - len(node.args.defaults)) + [ast.unparse(d) for d in node.args.defaults]
    return [(a.arg, d) for a, d in zip(args, defaults)]


def _runtime_params(obj, skip_self: bool) -> list[tuple[str, str | None]]:
    signature = inspect.signature(obj)
    params = list(signature.parameters.values())
    if skip_self and params and params[0].name in ("self", "$self"):
        params = params[1:]
    out = []
    for p in params:
        assert p.kind in (p.POSITIONAL_OR_KEYWORD, p.POSITIONAL_ONLY), f"{obj}: {p}"
        out.append((p.name, None if p.default is p.empty else repr(p.default).replace("'", '"')))
    return out


def _norm(params):
    return [(n, None if d is None else d.replace("'", '"')) for n, d in params]


def test_every_export_is_in_the_stub_and_back():
    tree = _stub_tree()
    stub_names = set()
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            stub_names.add(node.name)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            stub_names.add(node.target.id)
    runtime = {name for name in dir(_native) if not name.startswith("_")} | {"__version__"}
    private_aliases = {n for n in stub_names if n.startswith("_") and n != "__version__"}
    assert stub_names - private_aliases == runtime


def test_function_signatures_match():
    checked = 0
    for node in _stub_tree().body:
        if isinstance(node, ast.FunctionDef):
            assert _norm(_params(node, False)) == _runtime_params(getattr(_native, node.name), False), node.name
            checked += 1
    assert checked == sum(1 for n in dir(_native) if callable(getattr(_native, n)) and not isinstance(getattr(_native, n), type))


def test_class_members_match():
    for node in _stub_tree().body:
        if not isinstance(node, ast.ClassDef) or issubclass(getattr(_native, node.name), BaseException):
            continue
        cls = getattr(_native, node.name)
        runtime_members = {n for n in vars(cls) if not n.startswith("_")}
        stub_members = set()
        for item in node.body:
            if not isinstance(item, ast.FunctionDef):
                continue
            if item.name == "__init__":
                assert _norm(_params(item, True)) == _runtime_params(cls, False), f"{node.name}.__init__"
                continue
            stub_members.add(item.name)
            is_property = any(ast.unparse(d) == "property" for d in item.decorator_list)
            member = vars(cls)[item.name]
            if is_property:
                assert inspect.isdatadescriptor(member), f"{node.name}.{item.name} is not a property"
            else:
                assert _norm(_params(item, True)) == _runtime_params(member, True), f"{node.name}.{item.name}"
        assert stub_members == runtime_members, node.name


def test_exception_hierarchy_matches():
    for node in _stub_tree().body:
        if isinstance(node, ast.ClassDef) and node.bases:
            base = ast.unparse(node.bases[0])
            cls = getattr(_native, node.name)
            assert cls.__mro__[1].__name__ == base, node.name
            assert cls.__module__ == "unicac"


def test_the_package_exports_every_native_name():
    public = {n for n in dir(_native) if not n.startswith("_")}
    # `main` is the `unicac` command's entry point (unicac.cli), not part of the library's API.
    assert public <= set(unicac.__all__) | {"STATUS_NAMES", "main"}
    for name in unicac.__all__:
        assert hasattr(unicac, name), name
