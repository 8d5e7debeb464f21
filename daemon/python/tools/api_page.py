"""Print the Markdown page of the Python package's API (``docs/python-api.md``) from its
docstrings: a section for each public module, and in it each name of the module's
``__all__`` with its signature and docstring (a class's with its fields, attributes,
properties and methods). ``tests/test_api_page.py`` keeps the page equal to what this prints
and every name on it documented. Run from the repository:

    PYTHONPATH=daemon/python python3 daemon/python/tools/api_page.py > docs/python-api.md
"""

from __future__ import annotations

import ast
import dataclasses
import importlib
import inspect
import os
import re
from dataclasses import dataclass
from types import ModuleType
from typing import Any, Callable, Dict, Iterator, List, Optional, Tuple

MODULES = ("hapticd", "hapticd.telemetry", "hapticd.world")
"""The modules on the page, in its order."""

LISTED = {"field": "Fields", "attribute": "Attributes", "property": "Properties"}
"""The kinds of name listed under their class, a bullet each, by the label opening the list."""


@dataclass(frozen=True)
class Entry:
    """One documented name on the page."""

    name: str
    """Its full name, ``hapticd.Device.touches``."""
    kind: str
    """module, class, function, constant, method, one of :data:`LISTED`, or see (a name
    another module re-exports)."""
    shown: str
    """Its signature or declaration as the page shows it (empty for a module)."""
    doc: str
    """Its docstring, cleaned of its indentation; empty when it has none."""
    see: Optional[str] = None
    """The module that documents it, for a see."""


class _Unquoted(str):
    """An annotation written as a string, shown in a signature as written, not quoted."""

    def __repr__(self) -> str:
        return str(self)


def _signature(function: Callable[..., Any], drop_first: bool = False) -> str:
    """``function``'s parameters and return annotation (none for a class), as written in
    its source."""
    signature = inspect.signature(function)
    if inspect.isclass(function):
        signature = signature.replace(return_annotation=signature.empty)
    parameters = list(signature.parameters.values())[1 if drop_first else 0 :]
    shown = [
        p if p.annotation is p.empty else p.replace(annotation=_Unquoted(p.annotation))
        for p in parameters
    ]
    returned = signature.return_annotation
    if returned is not signature.empty:
        returned = _Unquoted(returned)
    return str(signature.replace(parameters=shown, return_annotation=returned))


@dataclass(frozen=True)
class _Assigned:
    """A name's assignment in the source."""

    value: str
    """The value, as written."""
    annotation: str
    """Its annotation, as written; empty for none."""
    doc: str
    """The docstring written under it; empty for none."""


class _Source:
    """What a package module's source says and no object can: the docstring written under an
    assignment (of the module, a class or ``self`` in ``__init__``), the value assigned and
    the annotation as written, and where each imported name comes from."""

    def __init__(self, module: ModuleType) -> None:
        with open(inspect.getfile(module)) as f:
            self.text = f.read()
        tree = ast.parse(self.text)
        self.package = module.__name__ if hasattr(module, "__path__") else module.__package__
        self.imported: Dict[str, str] = {}
        for node in tree.body:
            if isinstance(node, ast.ImportFrom) and node.level == 1:
                for alias in node.names:
                    self.imported[alias.asname or alias.name] = f"{self.package}.{node.module}"
        self.assigned = dict(self._documented(tree.body))
        self.classes: Dict[str, Dict[str, _Assigned]] = {}
        for node in tree.body:
            if isinstance(node, ast.ClassDef):
                members = dict(self._documented(node.body))
                for item in node.body:
                    if isinstance(item, ast.FunctionDef) and item.name == "__init__":
                        members.update(self._documented_in(item))
                self.classes[node.name] = members

    def _documented(
        self, body: List[ast.stmt], on_self: bool = False
    ) -> Iterator[Tuple[str, _Assigned]]:
        """Each name assigned in ``body``, or with ``on_self`` each ``self.name``, and how."""
        for statement, after in zip(body, body[1:] + [None]):
            if isinstance(statement, ast.Assign) and len(statement.targets) == 1:
                target = statement.targets[0]
            elif isinstance(statement, ast.AnnAssign):
                target = statement.target
            else:
                continue
            if on_self:
                if not (
                    isinstance(target, ast.Attribute)
                    and isinstance(target.value, ast.Name)
                    and target.value.id == "self"
                ):
                    continue
                name = target.attr
            elif isinstance(target, ast.Name):
                name = target.id
            else:
                continue
            annotation = getattr(statement, "annotation", None)
            doc = ""
            if (
                isinstance(after, ast.Expr)
                and isinstance(after.value, ast.Constant)
                and isinstance(after.value.value, str)
            ):
                doc = inspect.cleandoc(after.value.value)
            yield name, _Assigned(self._written(statement.value), self._written(annotation), doc)

    def _written(self, node: Optional[ast.expr]) -> str:
        """``node`` as its source writes it; empty for None."""
        return "" if node is None else ast.get_source_segment(self.text, node) or ""

    def _documented_in(self, function: ast.FunctionDef) -> Iterator[Tuple[str, _Assigned]]:
        """The ``self.name`` attributes that ``function`` sets, at any depth of its blocks."""
        for node in ast.walk(function):
            for field in ("body", "orelse", "finalbody"):
                block = getattr(node, field, None)
                if isinstance(block, list):
                    for name, found in self._documented(block, on_self=True):
                        yield name, found


def _sources() -> Dict[str, _Source]:
    """Every module of the package by name, read."""
    package = importlib.import_module(MODULES[0])
    names = [
        f"{package.__name__}.{os.path.splitext(f)[0]}"
        for f in sorted(os.listdir(os.path.dirname(inspect.getfile(package))))
        if f.endswith(".py") and f != "__init__.py"
    ]
    return {n: _Source(importlib.import_module(n)) for n in [package.__name__, *names]}


def _defined_in(sources: Dict[str, _Source], module: str, name: str) -> str:
    """The module whose source defines ``name``, following ``module``'s imports."""
    while name in sources[module].imported:
        module = sources[module].imported[name]
    return module


def _doc(text: Optional[str]) -> str:
    """A docstring cleaned of its indentation; empty for none."""
    return inspect.cleandoc(text) if text else ""


def _class_entries(cls: type, full: str, members: Dict[str, _Assigned]) -> Iterator[Entry]:
    """The entries of class ``cls`` (called ``full``) and its public members."""
    bases = ", ".join(b.__name__ for b in cls.__bases__ if b is not object)
    shown = f"class {cls.__name__}{_signature(cls)}" + (f"  # bases: {bases}" if bases else "")
    yield Entry(full, "class", shown, _doc(cls.__doc__))
    fields = [f.name for f in dataclasses.fields(cls)] if dataclasses.is_dataclass(cls) else []
    for name, assigned in members.items():
        if name.startswith("_"):
            continue
        kind = "field" if name in fields else "attribute"
        shown = f"{name}: {assigned.annotation}" if assigned.annotation else name
        yield Entry(f"{full}.{name}", kind, shown, assigned.doc)
    public = [(n, v) for n, v in vars(cls).items() if not n.startswith("_")]
    # The properties listed together, before the methods.
    for name, value in public:
        if isinstance(value, property):
            returned = getattr(value.fget, "__annotations__", {}).get("return", "")
            yield Entry(f"{full}.{name}", "property", f"{name}: {returned}", _doc(value.__doc__))
    for name, value in public:
        if inspect.isfunction(value):
            shown = f"{cls.__name__}.{name}{_signature(value, drop_first=True)}"
            yield Entry(f"{full}.{name}", "method", shown, _doc(value.__doc__))


def entries() -> List[Entry]:
    """Every name the page documents, in its order."""
    sources = _sources()
    out: List[Entry] = []
    for module_name in MODULES:
        module = importlib.import_module(module_name)
        out.append(Entry(module_name, "module", "", _doc(module.__doc__)))
        for name in module.__all__:
            full = f"{module_name}.{name}"
            home = _defined_in(sources, module_name, name)
            if home != module_name and home in MODULES:
                out.append(Entry(full, "see", "", "", see=home))
                continue
            value = getattr(module, name)
            source = sources[home]
            if inspect.isclass(value) and name in source.classes:
                out.extend(_class_entries(value, full, source.classes[name]))
            elif inspect.isfunction(value):
                out.append(Entry(full, "function", f"{name}{_signature(value)}",
                                 _doc(value.__doc__)))
            else:
                assigned = source.assigned[name]
                out.append(Entry(full, "constant", f"{name} = {assigned.value}", assigned.doc))
    return out


def _markdown(doc: str) -> str:
    """A docstring's reStructuredText roles and literals as Markdown code."""
    doc = re.sub(r":[a-z]+:`~?([^`]+)`", r"`\1`", doc)
    return re.sub(r"``([^`]+)``", r"`\1`", doc)


def _anchor(heading: str) -> str:
    """The anchor a Markdown renderer gives ``heading``."""
    return re.sub(r"[^a-z0-9_ -]", "", heading.lower()).replace(" ", "-")


def page() -> str:
    """The page, Markdown."""
    found = entries()
    lines = [
        "# The Python API",
        "",
        "<!-- Generated by daemon/python/tools/api_page.py from the package's docstrings: edit",
        "     those and run it; tests/test_api_page.py fails while this page differs. -->",
        "",
        "Every public name of the Python package in `daemon/python` (see",
        "[the bus chapter](bus-api.md#python) for the package at work), with its signature and",
        "docstring.",
        "",
    ]
    lines += [f"- [{e.name}](#{_anchor(e.name)})" for e in found if e.kind == "module"]
    listed: Optional[str] = None
    for e in found:
        if e.kind in LISTED:
            if listed != e.kind:
                lines += ["", f"{LISTED[e.kind]}:", ""]
                listed = e.kind
            doc = " ".join(_markdown(e.doc).split())
            lines.append(f"- `{e.shown}`" + (f": {doc}" if doc else ""))
            continue
        listed = None
        if e.kind == "see":
            short = e.name.rsplit(".", 1)[1]
            target = f"{e.see}.{short}"
            lines += ["", f"`{e.name}` is [`{target}`](#{_anchor(target)})."]
            continue
        level = {"module": "##", "method": "####"}.get(e.kind, "###")
        lines += ["", f"{level} {e.name}", ""]
        if e.shown:
            lines += ["```python", e.shown, "```", ""]
        lines.append(_markdown(e.doc))
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    print(page(), end="")
