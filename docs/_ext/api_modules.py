"""The API reference: the line ``<!-- api-modules -->`` of api.md becomes a section per
package of soilbin (its docstring) with a subsection per module (autodoc of its documented
members), found by walking the package, so that a new module appears without an edit."""
import pkgutil

from sphinx.errors import ExtensionError

import soilbin

PAGE = "api"
MARKER = "<!-- api-modules -->"


def _automodule(name, members):
    """An automodule directive, in reStructuredText: autodoc writes reStructuredText."""
    options = [":members:", ":show-inheritance:"] if members else []
    return ["```{eval-rst}", f".. automodule:: {name}", *("   " + o for o in options), "```", ""]


def _packages():
    """{package: [its modules]}, soilbin's own modules under soilbin itself."""
    packages = {"soilbin": []}
    for module in pkgutil.walk_packages(soilbin.__path__, "soilbin."):
        if module.ispkg:
            packages[module.name] = []
        else:
            packages[module.name.rpartition(".")[0]].append(module.name)
    return packages


def markdown():
    """The sections, as MyST Markdown with autodoc directives."""
    lines = []
    for package, modules in _packages().items():
        lines += [f"## {package}", ""]
        if package != "soilbin":
            lines += _automodule(package, members=False)
        for module in modules:
            lines += [f"### {module}", ""] + _automodule(module, members=True)
    return "\n".join(lines)


def insert_modules(app, docname, source):
    if docname != PAGE:
        return
    if MARKER not in source[0]:
        raise ExtensionError(f"{PAGE}.md: no {MARKER} line for the API reference")
    source[0] = source[0].replace(MARKER, markdown())


def read_again(app, env, added, changed, removed):
    """The page is made from the code: read it at every build."""
    return [PAGE]


def setup(app):
    app.connect("source-read", insert_modules)
    app.connect("env-get-outdated", read_again)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
