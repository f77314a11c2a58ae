#!/usr/bin/env python3
"""Size limits of the code (a ctest test): no source file in formats/, libcommon/ or libguide/ over
MAX_FILE lines, no function in tools/render/ or libguide/ over MAX_FUNCTION lines (from the first line
of its signature to its closing brace). Functions are found by a crude brace matcher over the text with
comments, strings and character literals blanked: a brace block at namespace or class scope whose head
(the text since the previous ';', '{' or '}') has a ')' and is no class, struct, enum or namespace.
Usage: check_sizes.py SOURCE_DIR [--report N]  (--report: print the N largest files and longest
functions of tools/render and libguide, and exit 0)"""
import os
import re
import sys

MAX_FILE = 700
MAX_FUNCTION = 150
FILE_DIRS = ("formats", "libcommon", "libguide")
FUNCTION_DIRS = ("tools/render", "libguide")
SOURCES = (".cpp", ".h")


def sources(src, top):
    for dirpath, _, files in os.walk(os.path.join(src, top)):
        for name in sorted(files):
            if name.endswith(SOURCES):
                path = os.path.join(dirpath, name)
                yield path, os.path.relpath(path, src).replace(os.sep, "/")


def blank(text):
    """The text with comments, string and character literals replaced by spaces (newlines kept)."""
    out = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c == 'R' and text.startswith('R"', i):
            m = re.match(r'R"([^(]*)\(', text[i:])
            end = text.find(")" + m.group(1) + '"', i) if m else -1
            j = n if end < 0 else end + len(m.group(1)) + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c in "\"'":
            if c == "'" and i > 0 and (text[i - 1].isalnum()):
                out.append(c)  # a digit separator (1'000)
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            j = min(n, j + 1)
            out.append(" " * (j - i))
            i = j
        else:
            out.append(c)
            i += 1
    return "".join(out)


def functions(text):
    """(name, first line, last line) of every function body at namespace or class scope."""
    # Preprocessor lines (with their continuations) are no part of any head.
    t = re.sub(r"(?m)^[ \t]*#(?:[^\n]*\\\n)*[^\n]*", lambda m: re.sub(r"[^\n]", " ", m.group(0)), blank(text))
    result = []
    stack = []  # kinds of the open blocks: 'ns', 'class', 'func', 'other'
    head_start = 0
    starts = [0]  # offset of each line's start
    for k, ch in enumerate(t):
        if ch == "\n":
            starts.append(k + 1)

    def line_of(off):
        lo, hi = 0, len(starts) - 1
        while lo < hi:
            mid = (lo + hi + 1) // 2
            if starts[mid] <= off:
                lo = mid
            else:
                hi = mid - 1
        return lo + 1

    for k, ch in enumerate(t):
        if ch == "{":
            head = t[head_start:k]
            if any(kind in ("func", "other", "inner") for kind, _, _ in stack):
                kind = "inner"
            elif re.search(r"\bnamespace\b|\bextern\s*$", head) or head.strip() == "":
                kind = "ns" if re.search(r"\bnamespace\b", head) else "other"
            elif re.search(r"\b(class|struct|union|enum)\b", head) and not re.search(r"\)\s*(const\s*)?(noexcept\s*)?(->[^{]*)?$", head.strip()):
                kind = "class"
            elif ")" in head and not re.search(r"=\s*$", head.strip()):
                kind = "func"
            else:
                kind = "other"
            if kind == "func":
                first = head_start + (len(head) - len(head.lstrip()))
                name = re.findall(r"([A-Za-z_~][\w:~<>]*)\s*\(", head)
                stack.append(("func", name[0] if name else "?", line_of(first)))
            else:
                stack.append((kind, None, None))
            head_start = k + 1
        elif ch == "}":
            if stack:
                kind, name, first = stack.pop()
                if kind == "func":
                    result.append((name, first, line_of(k)))
            head_start = k + 1
        elif ch == ";":
            head_start = k + 1
        elif ch == ":" and not (k + 1 < len(t) and t[k + 1] == ":") and not (k > 0 and t[k - 1] == ":"):
            # access specifiers (public:) end a head; constructor initialiser lists' ':' follow a ')'
            if re.search(r"\b(public|private|protected)\s*$", t[head_start:k]):
                head_start = k + 1
    return result


def measure(src):
    files, funcs = [], []
    for top in sorted(set(FILE_DIRS) | set(FUNCTION_DIRS)):
        for path, rel in sources(src, top):
            with open(path, encoding="utf-8", errors="replace") as f:
                text = f.read()
            files.append((text.count("\n"), rel))
            if rel.startswith(tuple(d + "/" for d in FUNCTION_DIRS)):
                for name, a, b in functions(text):
                    funcs.append((b - a + 1, rel + ":" + str(a), name))
    return files, funcs


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    src = sys.argv[1]
    files, funcs = measure(src)
    if "--report" in sys.argv:
        n = int(sys.argv[sys.argv.index("--report") + 1])
        print("largest files (lines):")
        for lines, rel in sorted(files, reverse=True)[:n]:
            print("  %5d %s" % (lines, rel))
        print("longest functions (lines) in %s:" % ", ".join(FUNCTION_DIRS))
        for lines, where, name in sorted(funcs, reverse=True)[:n]:
            print("  %5d %s %s" % (lines, name, where))
        return 0
    bad = 0
    for lines, rel in files:
        if rel.split("/")[0] in FILE_DIRS and lines > MAX_FILE:
            print("size error: %s has %d lines (at most %d in %s)" % (rel, lines, MAX_FILE, ", ".join(FILE_DIRS)))
            bad += 1
    for lines, where, name in funcs:
        if lines > MAX_FUNCTION:
            print("size error: %s: function %s has %d lines (at most %d in %s)" % (
                where, name, lines, MAX_FUNCTION, ", ".join(FUNCTION_DIRS)))
            bad += 1
    if not bad:
        print("sizes ok: %d files, %d functions measured" % (len(files), len(funcs)))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
