#!/usr/bin/env python3
"""The project's layering, checked over every source file's #include lines (run by every build and by
ctest). A folder may include only what is below it:
  libcommon/       libcommon
  formats/         formats, libcommon
  libguide/        libguide, formats, libcommon
  tools/X/         tools/X, tools/common, libguide, formats, libcommon (never another tool's folder)
  tests/           anything
Prints one line per forbidden include and exits 1 if there is any. Usage: check_layering.py SOURCE_DIR"""
import os
import re
import sys

ROOTS = ("libcommon", "formats", "libguide", "tools", "tests")
ALLOWED = {
    "libcommon": ("libcommon",),
    "formats": ("formats", "libcommon"),
    "libguide": ("libguide", "formats", "libcommon"),
}
INCLUDE = re.compile(r'^\s*#\s*include\s*([<"])([^>"]+)[>"]')
SOURCES = (".c", ".cc", ".cpp", ".h", ".hpp", ".inc")


def allowed_for(rel):
    """The include prefixes a file at `rel` (relative to the source dir) may use; None = unrestricted."""
    parts = rel.split("/")
    if parts[0] in ALLOWED:
        return tuple(p + "/" for p in ALLOWED[parts[0]])
    if parts[0] == "tools" and len(parts) > 2:
        return ("tools/" + parts[1] + "/", "tools/common/", "libguide/", "formats/", "libcommon/")
    return None


def check(src):
    errors = []
    for top in ("libcommon", "formats", "libguide", "tools"):
        for dirpath, _, files in os.walk(os.path.join(src, top)):
            for name in sorted(files):
                if not name.endswith(SOURCES):
                    continue
                path = os.path.join(dirpath, name)
                rel = os.path.relpath(path, src).replace(os.sep, "/")
                allowed = allowed_for(rel)
                if allowed is None:
                    continue
                with open(path, encoding="utf-8", errors="replace") as f:
                    for lineno, line in enumerate(f, 1):
                        m = INCLUDE.match(line)
                        if not m:
                            continue
                        target = m.group(2)
                        first = target.split("/")[0]
                        if "/" not in target and m.group(1) == '"':
                            continue  # the same folder
                        if first not in ROOTS:
                            continue  # a system or third-party header
                        if not target.startswith(allowed):
                            errors.append("%s:%d: includes %s; %s may include only %s" % (
                                rel, lineno, target, rel.rsplit("/", 1)[0] + "/",
                                ", ".join(a.rstrip("/") for a in allowed)))
    return errors


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: check_layering.py SOURCE_DIR")
    errs = check(sys.argv[1])
    for e in errs:
        print("layering error: " + e, file=sys.stderr)
    sys.exit(1 if errs else 0)
