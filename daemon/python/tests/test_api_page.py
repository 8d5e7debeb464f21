"""The Python API page of the docs (docs/python-api.md) is what tools/api_page.py makes of
the package as it is, and every name on it has a docstring."""

import importlib.util
import os
import sys

HERE = os.path.dirname(__file__)
PAGE = os.path.join(HERE, "../../../docs/python-api.md")

_spec = importlib.util.spec_from_file_location(
    "api_page", os.path.join(HERE, "../tools/api_page.py")
)
api_page = importlib.util.module_from_spec(_spec)
# Registered before it runs: its dataclasses look their module up.
sys.modules[_spec.name] = api_page
_spec.loader.exec_module(api_page)


def test_the_api_page_is_made_from_the_package_as_it_is():
    with open(PAGE) as f:
        written = f.read()
    assert written == api_page.page(), (
        "docs/python-api.md is stale: PYTHONPATH=daemon/python "
        "python3 daemon/python/tools/api_page.py > docs/python-api.md"
    )


def test_every_public_name_has_a_docstring():
    entries = api_page.entries()
    assert len(entries) > 50
    assert [e.name for e in entries if not e.doc and e.kind != "see"] == []
