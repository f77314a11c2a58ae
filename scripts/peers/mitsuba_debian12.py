#!/usr/bin/env python3
"""Edit a copy of a Mitsuba 0.5.0 source tree (the mitsuba/ folder of
Tom94/practical-path-guiding) so that its own SCons build runs on Debian 12.

Usage: mitsuba_debian12.py MITSUBA_DIR [--spectrum-fix]

Every edit checks that the text it replaces is present, so a tree that differs
from the one these edits were written for stops the build with one line naming
the file, instead of building something else.  Running it twice is harmless:
an edit whose result is already present is skipped.

The edits change how the program is built, never what it computes, except
two: the independent sampler reads an optional `seed` (see sampler_seed; a
scene without one renders as before), and --spectrum-fix (see SPECTRUM_OLD
below), which is off unless asked for.
"""
import os
import re
import subprocess
import sys

PROG = "mitsuba_debian12"


def die(msg):
    sys.stderr.write(f"{PROG}: error: {msg}\n")
    sys.exit(1)


def read(path):
    with open(path, encoding="utf-8", errors="surrogateescape") as f:
        return f.read()


def write(path, text):
    with open(path, "w", encoding="utf-8", errors="surrogateescape") as f:
        f.write(text)


def replace(root, rel, old, new, count=None):
    """Replace `old` by `new` in root/rel; `count` = how many occurrences the
    tree must hold (None: at least one)."""
    path = os.path.join(root, rel)
    text = read(path)
    if new in text:
        return  # already applied (checked first: some replacements contain the text they replace)
    n = text.count(old)
    if n == 0:
        die(f"{path}: expected text not found: {old!r}")
    if count is not None and n != count:
        die(f"{path}: expected {count} occurrence(s) of {old!r}, found {n}")
    write(path, text.replace(old, new))


# --- 1. SCons scripts: Python 2 -> Python 3 --------------------------------
# Debian 12's SCons 4.4 runs on Python 3 only; Mitsuba 0.5's build scripts use
# `print '...'`, `dict.has_key` and `except E, e`.  lib2to3 (still shipped
# with Python 3.11) rewrites exactly those constructs and nothing else.
def scons_python3(root):
    if "print '" not in read(os.path.join(root, "build", "SConscript.configure")):
        return  # already converted (lib2to3 would wrap the prints in parentheses again)
    files = [os.path.join(root, "SConstruct")]
    files += [os.path.join(root, "build", f) for f in sorted(os.listdir(os.path.join(root, "build")))
              if f.startswith("SConscript")]
    src = os.path.join(root, "src")
    files += [os.path.join(src, d, "SConscript") for d in sorted(os.listdir(src))
              if os.path.isfile(os.path.join(src, d, "SConscript"))]
    cmd = [sys.executable, "-W", "ignore", "-m", "lib2to3", "-w", "-n",
           "-f", "print", "-f", "has_key", "-f", "except"] + files
    r = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        die("lib2to3 failed on the SCons scripts: " + r.stderr.strip().splitlines()[-1])
    # The Intel-compiler tool `icl12` is Python-2 only and never needed with g++.
    replace(root, "build/SConscript.configure", ", 'icl12']", "]", count=2)


# --- 2. config.py: the authors' Linux g++ configuration, Debian 12 libraries ---
def config_py(root):
    text = read(os.path.join(root, "build", "config-linux-gcc.py"))
    # Mitsuba 0.5 predates C++17 (dynamic exception specifications); g++ 12
    # defaults to C++17.
    text = text.replace("'-mtls-dialect=gnu2']", "'-mtls-dialect=gnu2', '-std=gnu++14']")
    # OpenEXR 3 split Imath (and half) out of IlmBase; IlmImf became OpenEXR.
    text = text.replace("OEXRINCLUDE    = ['/usr/include/OpenEXR']",
                        "OEXRINCLUDE    = ['/usr/include/OpenEXR', '/usr/include/Imath']")
    text = text.replace("OEXRLIB        = ['Half', 'IlmImf', 'z']",
                        "OEXRLIB        = ['OpenEXR', 'Imath', 'Iex', 'IlmThread', 'z']")
    # GLEW 2 dropped the multi-context variant GLEW-MX.
    text = text.replace("'GLEWmx'", "'GLEW'")
    text = text.replace("GLFLAGS        = ['-DGLEW_MX']", "GLFLAGS        = []")
    # COLLADA-DOM and boost-python are not packaged here: no converter, no bindings.
    lines = [l for l in text.splitlines() if not l.startswith(("COLLADA",))]
    cut = next((i for i, l in enumerate(lines) if l.startswith("# The following runs a helper script")), None)
    if cut is not None:
        lines = lines[:cut]
    text = "\n".join(lines).rstrip() + "\n"
    for needed in ("'-std=gnu++14'", "'/usr/include/Imath'", "'OpenEXR', 'Imath'", "GLFLAGS        = []",
                   "-DSPECTRUM_SAMPLES=3"):
        if needed not in text:
            die(f"{root}/build/config-linux-gcc.py: not the expected configuration ({needed} not set)")
    write(os.path.join(root, "config.py"), text)


# --- 3. Sources: OpenEXR 3, GLEW 2, Boost 1.74 ----------------------------------
def sources(root):
    # OpenEXR 3 removed the Imf::Int64 alias (it is uint64_t) and no longer
    # pulls FrameBuffer in through the other headers.
    replace(root, "src/libcore/bitmap.cpp", "Imf::Int64", "uint64_t", count=4)
    replace(root, "src/libcore/bitmap.cpp", "#include <ImfIO.h>\n",
            "#include <ImfIO.h>\n#include <ImfFrameBuffer.h>\n", count=1)
    # Without GLEW-MX there is no per-thread GLEW context to provide.
    replace(root, "src/libhw/glrenderer.cpp",
            "static mitsuba::PrimitiveThreadLocal<GLEWContextStruct> glewContext;\n\n"
            "GLEWContextStruct *glewGetContext() {\n\treturn &glewContext.get();\n}\n",
            "#if defined(GLEW_MX)\n"
            "static mitsuba::PrimitiveThreadLocal<GLEWContextStruct> glewContext;\n\n"
            "GLEWContextStruct *glewGetContext() {\n\treturn &glewContext.get();\n}\n"
            "#endif\n", count=1)
    replace(root, "include/mitsuba/hw/glrenderer.h",
            "struct GLEWContextStruct;\n\n/// Get the per-thread context for GLEW-MX\n"
            "extern MTS_EXPORT_HW GLEWContextStruct *glewGetContext();\n",
            "#if defined(GLEW_MX)\nstruct GLEWContextStruct;\n\n/// Get the per-thread context for GLEW-MX\n"
            "extern MTS_EXPORT_HW GLEWContextStruct *glewGetContext();\n#endif\n", count=1)
    # Boost 1.74 no longer puts the bind placeholders in the global namespace.
    replace(root, "src/volume/volcache.cpp", "this, _1)", "this, boost::placeholders::_1)", count=2)


# --- 4. The independent sampler takes a seed ----------------------------------
# Mitsuba 0.5's independent sampler seeds its generator with one fixed seed,
# and each render thread's clone is seeded from it, so two renders of one
# scene repeat the same random numbers (only the thread scheduling differs):
# they cannot measure a reference's own noise.  An optional integer `seed`
# (absent: the fixed seed, exactly as before) gives independent renders.
def sampler_seed(root):
    replace(root, "src/samplers/independent.cpp",
            "\t\tm_random = new Random();\n\t}",
            "\t\t/* iris's build: an optional seed, so that renders can be independent */\n"
            "\t\tif (props.hasProperty(\"seed\"))\n"
            "\t\t\tm_random = new Random((uint64_t) props.getLong(\"seed\"));\n"
            "\t\telse\n\t\t\tm_random = new Random();\n\t}", count=1)


# --- 5. Optional: tabulated spectra interpolated forwards ------------------------
# Mitsuba 0.5.0's InterpolatedSpectrum::eval evaluates lerp(t, fb, fa) with
# t = (lambda - a) / (b - a): at lambda = a it returns the value tabulated at b,
# i.e. each segment is interpolated backwards.  The 0.6 core evaluates
# lerp(t, fa, fb).  In an RGB build this changes the RGB of every
# <spectrum value="l1:v1, l2:v2, ..."> in a scene.
SPECTRUM_OLD = "return math::lerp((lambda - a) / (b-a), fb, fa);"
SPECTRUM_NEW = "return math::lerp((lambda - a) / (b-a), fa, fb);"


def spectrum(root, fix):
    path = "src/libcore/spectrum.cpp"
    text = read(os.path.join(root, path))
    old, new = (SPECTRUM_OLD, SPECTRUM_NEW) if fix else (SPECTRUM_NEW, SPECTRUM_OLD)
    if text.count(old) + text.count(new) != 1:
        die(f"{root}/{path}: InterpolatedSpectrum::eval's interpolation line not found")
    if old in text:
        write(os.path.join(root, path), text.replace(old, new))


def main(argv):
    args = [a for a in argv if not a.startswith("--")]
    flags = [a for a in argv if a.startswith("--")]
    if len(args) != 1 or any(f != "--spectrum-fix" for f in flags):
        die("usage: mitsuba_debian12.py MITSUBA_DIR [--spectrum-fix]")
    root = args[0]
    if not os.path.isfile(os.path.join(root, "SConstruct")) or \
       not os.path.isfile(os.path.join(root, "build", "config-linux-gcc.py")):
        die(f"{root}: not a Mitsuba source folder (no SConstruct / build/config-linux-gcc.py)")
    scons_python3(root)
    config_py(root)
    sources(root)
    sampler_seed(root)
    spectrum(root, "--spectrum-fix" in flags)


if __name__ == "__main__":
    main(sys.argv[1:])
