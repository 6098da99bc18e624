"""Kernels loaded from numba's cache without setting up numba's compiler first.

numba's `Cache.load_overload` refreshes the target context before it loads: it imports
and installs every registry of typing templates and lowerings (numpy, linalg, the typed
containers, ...). A compile needs them; a cached kernel is machine code, and it needs
only the symbols it links to: numba's C helpers and exception classes, which the context
installs when it is made, and the reference-counting runtime (NRT), which the refresh
initialises and so is initialised here. numba refreshed 265 times in a render of
Sierpinski, the first time importing and installing everything; without it the wall time
of `pcsg render` fell by 0.09 to 0.13 s (tools/performance_notes.md). A kernel that is not
cached still compiles as before: numba's compiler refreshes both contexts itself
(`CompilerBase.__init__`).

A cached library is machine code and the library's LLVM module as bitcode. numba parses
that bitcode at every load, to list the symbols the library defines (how it finds a
kernel's entry points), and in case a compile links the library into new code later. The
parse was most of each load: 30 of the shading kernel's 37 ms, 60 ms of the loads of a
terrain render. Here the names come from the object file's own symbol table (the same
names, read in a tenth of a millisecond), and the bitcode is parsed only when a compile
links the library. An object file that is not ELF (macOS, Windows) loads as numba loads it.

numba's runtime (NRT: reference counts, allocation) is LLVM IR that numba compiles in
every process before the first kernel loads, 18 ms of every `pcsg` command. Its machine
code is kept in the user's cache directory (nrt-*.bin, by numba's and llvmlite's versions,
the CPU it was compiled for and the settings its IR depends on) and loaded like a kernel's
after the first time.

With a numba that lacks the methods used here, numba's own load stays."""
from __future__ import annotations

import hashlib
import os
import pickle
import struct
import tempfile

import llvmlite
import numba
from llvmlite import binding
from numba.core import codegen, config
from numba.core.caching import Cache
from numba.core.runtime import nrtdynmod

from ..caches import cache_dir

NUMBA_LOAD = Cache.load_overload        # kept for the test that compares the two
NUMBA_UNSERIALIZE = codegen.CPUCodeLibrary.__dict__.get("_unserialize")
NUMBA_LINKING = getattr(codegen.CPUCodeLibrary, "_get_module_for_linking", None)
NUMBA_NRT = nrtdynmod.compile_nrt_functions


def load_overload(self, sig, target_context):
    from numba.core.runtime import nrt
    nrt.rtsys.initialize(target_context)
    with self._guard_against_spurious_io_errors():
        return self._load_overload(sig, target_context)


def defined_symbols(object_code: bytes) -> set[str] | None:
    """The names of the functions and data an ELF-64 little-endian relocatable object
    defines (what numba reads off the bitcode: every definition, local ones too), or None
    for any other object format."""
    if object_code[:4] != b"\x7fELF" or object_code[4:6] != b"\x02\x01":
        return None
    shoff, = struct.unpack_from("<Q", object_code, 0x28)
    size, count = struct.unpack_from("<HH", object_code, 0x3A)
    sections = [struct.unpack_from("<IIQQQQIIQQ", object_code, shoff + i * size)
                for i in range(count)]
    names = set()
    for _, kind, _, _, offset, length, link, _, _, _ in sections:
        if kind != 2:                                   # SHT_SYMTAB
            continue
        strings = sections[link][4]
        for name, info, _, where, _, _ in struct.iter_unpack(
                "<IBBHQQ", object_code[offset:offset + length]):
            # defined (not SHN_UNDEF) data (STT_OBJECT) or functions (STT_FUNC)
            if name and where != 0 and info & 0xF in (1, 2):
                end = object_code.index(b"\0", strings + name)
                names.add(object_code[strings + name:end].decode())
    return names


def _unserialize(cls, codegen_, state):
    """numba's load of a cached library (CPUCodeLibrary._unserialize), with the symbols
    from the object file and the bitcode kept unparsed."""
    name, kind, data = state
    symbols = defined_symbols(data[0]) if kind == "object" else None
    if symbols is None or not hasattr(codegen_._engine, "_defined_symbols"):
        return NUMBA_UNSERIALIZE.__func__(cls, codegen_, state)
    object_code, bitcode = data
    library = codegen_.create_library(name)
    library.enable_object_caching()
    library._set_compiled_object(object_code)
    library._pcsg_bitcode = bitcode
    library._finalize_final_module()
    codegen_._engine._defined_symbols |= symbols
    return library


def _get_module_for_linking(self):
    """numba's, after parsing a loaded library's bitcode the first time it is linked."""
    bitcode = self.__dict__.pop("_pcsg_bitcode", None)
    if bitcode is not None:
        self._shared_module = binding.parse_bitcode(bitcode)
    return NUMBA_LINKING(self)


def runtime_file(ctx):
    """Where the runtime's machine code for this numba, llvmlite and CPU is kept."""
    key = repr((numba.__version__, llvmlite.__version__, ctx.codegen().magic_tuple(),
                config.OPT, config.DEBUG_NRT))
    return cache_dir() / f"nrt-{hashlib.sha256(key.encode()).hexdigest()[:20]}.bin"


def compile_nrt_functions(ctx):
    """numba's runtime library (nrtdynmod.compile_nrt_functions), read from the cache
    when an earlier process kept it, else compiled as numba does and kept."""
    path = runtime_file(ctx)
    try:
        return ctx.codegen().unserialize_library(pickle.loads(path.read_bytes()))
    except Exception:   # noqa: BLE001 -- none kept, or unreadable: compile it
        pass
    ir_module, library = nrtdynmod.create_nrt_module(ctx)
    library.enable_object_caching()
    library.add_ir_module(ir_module)
    library.finalize()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        # written whole, then renamed: another process may be reading it
        fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
        with os.fdopen(fd, "wb") as f:
            f.write(pickle.dumps(library.serialize_using_object_code()))
        os.replace(tmp, path)
    except OSError:
        pass            # a read-only home: compiled again next time
    return library


def install() -> None:
    if hasattr(Cache, "_load_overload") and hasattr(Cache, "_guard_against_spurious_io_errors"):
        Cache.load_overload = load_overload
    if isinstance(NUMBA_UNSERIALIZE, classmethod) and NUMBA_LINKING is not None:
        codegen.CPUCodeLibrary._unserialize = classmethod(_unserialize)
        codegen.CPUCodeLibrary._get_module_for_linking = _get_module_for_linking
    if hasattr(nrtdynmod, "create_nrt_module"):
        nrtdynmod.compile_nrt_functions = compile_nrt_functions
