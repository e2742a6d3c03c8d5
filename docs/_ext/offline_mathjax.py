"""Math without a network: the part of Debian's MathJax 2 (libjs-mathjax) that the
TeX-AMS_CHTML configuration loads, copied into the build's _static/mathjax (conf.py's
mathjax_path points there)."""
import shutil
from pathlib import Path

MATHJAX = Path("/usr/share/javascript/mathjax")
#: What TeX-AMS_CHTML loads besides its combined configuration: the TeX input, the
#: CommonHTML output with its TeX font data and web fonts, the MathML element tables and
#: the extensions (menu, zoom, AMS, assistive MathML).
LOADED = ("MathJax.js", "extensions", "jax/input/TeX", "jax/output/CommonHTML", "jax/element",
          "fonts/HTML-CSS/TeX/woff")


def copy_mathjax(app, exception):
    """After an HTML build: copy the configuration that mathjax_path names and LOADED
    (1.5 MB) into _static/mathjax."""
    if exception is not None or app.builder.format != "html":
        return
    config = app.config.mathjax_path.partition("?config=")[2]
    target = Path(app.outdir) / "_static" / "mathjax"
    for part in (f"config/{config}.js", *LOADED):
        source, copy = MATHJAX / part, target / part
        copy.parent.mkdir(parents=True, exist_ok=True)
        if source.is_dir():
            shutil.copytree(source, copy, dirs_exist_ok=True)
        else:
            shutil.copyfile(source, copy)


def setup(app):
    app.connect("build-finished", copy_mathjax)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
