"""The forms' just-in-time compilation: FFCx's C code, built as a plain shared library.

DOLFINx 0.5 builds each form, expression and element that FFCx generates as
a CPython extension module (cffi's API mode): every object, even a 3 kB
element, pays for parsing Python.h, cffi's wrapper code and a setuptools
build, about 0.3 CPU s of a first run's 0.5 s per object (22 objects for the
tine). :func:`install` makes ``dolfinx.jit.ffcx_jit`` compile the same C code
with the same compiler and flags into a shared library that holds only the
code, loaded with ``ctypes``; its structs are read through one cffi FFI that
declares the UFCx types (ABI mode). The kernels are the same machine code, so
the results are the same to the bit. The libraries live in DOLFINx's cache
folder (``~/.cache/fenics``) under names of their own (the signature carries
``ABI_TAG``), beside the extension modules that other programs build there.

``SOILBIN_JIT=cffi`` in the environment keeps DOLFINx's own compilation.
"""
import ctypes
import os
import shlex
import subprocess
import sysconfig
import tempfile
import types
from pathlib import Path

import cffi
import ffcx
import ffcx.codegeneration
import ffcx.codegeneration.jit as ffcx_jit_module
import ffcx.compiler
import ffcx.naming
import ufl
import dolfinx.jit

#: Part of every signature: a library built here is never taken for an extension module.
ABI_TAG = "soilbin-abi-1"

#: The C flags of cffi's build that can change the code (DOLFINx's
#: ``cffi_extra_compile_args`` come after them, as in cffi's command line).
BASE_FLAGS = ("-DNDEBUG", "-fwrapv", "-O2", "-fPIC", "-shared")

_ffis = {}       # scalar type -> FFI declaring the UFCx types
_libraries = {}  # module name -> ctypes.CDLL (never unloaded, like extension modules)
_dolfinx_jit = dolfinx.jit.ffcx_jit


def ufcx_ffi(scalar_type):
    """The cffi FFI (ABI mode) declaring the UFCx types of ``scalar_type``."""
    if scalar_type not in _ffis:
        ffi = cffi.FFI()
        j = ffcx_jit_module
        ffi.cdef(j.UFC_HEADER_DECL.format(scalar_type) + j.UFC_ELEMENT_DECL + j.UFC_DOFMAP_DECL
                 + j.UFC_INTEGRAL_DECL + j.UFC_FORM_DECL + j.UFC_EXPRESSION_DECL)
        _ffis[scalar_type] = ffi
    return _ffis[scalar_type]


def _kind(ufl_object):
    """(module name prefix, [(C type, symbol name function)]) of a UFL object, else None."""
    if isinstance(ufl_object, ufl.Form):
        return "libffcx_forms_", [("ufcx_form", lambda o, m: ffcx.naming.form_name(o, 0, m))]
    if isinstance(ufl_object, ufl.FiniteElementBase):
        return "libffcx_elements_", [("ufcx_finite_element", ffcx.naming.finite_element_name),
                                     ("ufcx_dofmap", ffcx.naming.dofmap_name)]
    if isinstance(ufl_object, tuple) and isinstance(ufl_object[0], ufl.core.expr.Expr):
        return "libffcx_expressions_", [("ufcx_expression", ffcx.naming.expression_name)]
    return None


def _compile(code, library, p_jit):
    """Build ``code`` into the shared library ``library`` (written under a temporary name
    and renamed: processes that build the same library at once do not clash)."""
    folder = library.parent
    fd, source = tempfile.mkstemp(dir=folder, prefix=library.stem + ".", suffix=".c")
    with os.fdopen(fd, "w") as f:
        f.write(code)
    built = Path(source).with_suffix(".so")
    command = (shlex.split(sysconfig.get_config_var("CC") or "cc") + list(BASE_FLAGS)
               + list(p_jit["cffi_extra_compile_args"] or ())
               + ["-I", ffcx.codegeneration.get_include_path(), source, "-o", str(built), "-lm"]
               + [f"-l{name}" for name in p_jit["cffi_libraries"] or ()])
    done = subprocess.run(command, capture_output=True, text=True)
    if p_jit["cffi_verbose"]:
        print(" ".join(command), done.stdout, done.stderr, sep="\n")
    if done.returncode != 0:
        os.replace(source, library.with_suffix(".c.failed"))
        raise RuntimeError(f"JIT compilation of {library.stem} failed:\n{done.stderr}")
    os.replace(source, library.with_suffix(".c"))
    os.replace(built, library)


def _local_jit(ufl_object, form_compiler_params={}, jit_params={}):
    """``dolfinx.jit.ffcx_jit`` (on one process) with the code in a plain shared library."""
    kind = _kind(ufl_object)
    if kind is None:
        return _dolfinx_jit.__wrapped__(ufl_object, form_compiler_params, jit_params)
    prefix, symbols = kind
    p = ffcx.get_parameters(form_compiler_params)
    p_jit = dolfinx.jit.get_parameters(jit_params)
    module_name = prefix + ffcx.naming.compute_signature(
        [ufl_object], ffcx_jit_module._compute_parameter_signature(p)
        + str(p_jit["cffi_extra_compile_args"]) + str(p_jit["cffi_debug"])
        + str(p_jit["cffi_libraries"]) + ABI_TAG)
    names = [name(ufl_object, module_name) for _, name in symbols]
    cache_dir = Path(p_jit["cache_dir"])
    library = cache_dir / (module_name + ".so")
    code = (None, None)
    if module_name not in _libraries:
        if not library.exists():
            cache_dir.mkdir(parents=True, exist_ok=True)
            _, body = ffcx.compiler.compile_ufl_objects([ufl_object], prefix=module_name,
                                                        parameters=p)
            _compile(body, library, p_jit)
            code = (None, body)
        _libraries[module_name] = ctypes.CDLL(str(library))
    lib = _libraries[module_name]
    ffi = ufcx_ffi(p["scalar_type"])
    objects = [ffi.cast(f"{ctype} *", ctypes.addressof(ctypes.c_char.in_dll(lib, name)))[0]
               for (ctype, _), name in zip(symbols, names)]
    module = types.SimpleNamespace(__name__=module_name, ffi=ffi, lib=lib)
    return (objects[0] if len(objects) == 1 else tuple(objects)), module, code


def install():
    """Route DOLFINx's JIT through :func:`_local_jit` (unless ``SOILBIN_JIT=cffi``)."""
    if os.environ.get("SOILBIN_JIT", "") == "cffi":
        dolfinx.jit.ffcx_jit = _dolfinx_jit
    else:
        dolfinx.jit.ffcx_jit = dolfinx.jit.mpi_jit_decorator(_local_jit)
