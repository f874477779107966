#!/usr/bin/env python3
"""Lists the longest functions of the project's C++ sources (the rule: none over 120 lines in
core/, analysis/, app/).

    scripts/function_lengths.py [--top N] [--limit L] [DIR ...]   (default: core analysis app)

A brace-matching scan, not a parser: comments, strings and character literals are blanked, then
every `{` opened at namespace or class scope whose preceding text has a parameter list `(...)`
(and is not a class, struct, enum, namespace or initialiser) starts a function, which ends at its
matching `}`. Length = lines from the line holding the function's name to the closing brace,
inclusive. Lambdas and local classes count toward the function that holds them. Prints
"lines  file:line  name", longest first; exit 1 when a function is longer than --limit (if given).
"""
import argparse
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent


def blank_comments_and_strings(text):
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
        elif text.startswith('R"', i):
            m = re.match(r'R"([^(\s]*)\(', text[i:])
            if m:
                end = text.find(")" + m.group(1) + '"', i)
                j = n if end < 0 else end + len(m.group(1)) + 2
                out.append(re.sub(r"[^\n]", " ", text[i:j]))
                i = j
            else:
                out.append(c)
                i += 1
        elif c in "\"'":
            j = i + 1
            while j < n and text[j] != c:
                j += 2 if text[j] == "\\" else 1
            j = min(n, j + 1)
            out.append(c + " " * (j - i - 2) + c if j - i >= 2 else text[i:j])
            i = j
        else:
            out.append(c)
            i += 1
    return "".join(out)


SCOPE = re.compile(r"\b(namespace|class|struct|union|enum)\b[^;()]*$|extern\s*\"\s*\"\s*$")


def functions(path):
    text = blank_comments_and_strings(path.read_text(errors="replace"))
    # stack of ("scope" | "function" | "other", start offset, name)
    stack = []
    found = []
    last_stop = 0  # offset after the last ; { or } at scope level
    for i, c in enumerate(text):
        if c == "{":
            in_function = any(kind != "scope" for kind, _, _ in stack)
            head = text[last_stop:i]
            if in_function:
                stack.append(("other", i, ""))
            elif SCOPE.search(head.strip()):
                stack.append(("scope", i, ""))
            elif re.search(r"\)\s*(const|noexcept|override|final|mutable|->[^{]*|:[^{]*|\s)*$", head) and "(" in head \
                    and not re.search(r"=\s*$", head.strip()):
                name = re.search(r"([~\w:<>]+)\s*\(", head)
                start = i - len(head) + (name.start(1) if name else 0)
                stack.append(("function", start, name.group(1) if name else "?"))
            else:
                stack.append(("other", i, ""))
            last_stop = i + 1
        elif c == "}":
            if stack:
                kind, start, name = stack.pop()
                if kind == "function":
                    first = text.count("\n", 0, start) + 1
                    last = text.count("\n", 0, i) + 1
                    found.append((last - first + 1, first, name))
            last_stop = i + 1
        elif c == ";" and not any(kind != "scope" for kind, _, _ in stack):
            last_stop = i + 1
    return found


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dirs", nargs="*", default=["core", "analysis", "app"])
    ap.add_argument("--top", type=int, default=10)
    ap.add_argument("--limit", type=int, default=0)
    a = ap.parse_args()
    rows = []
    for d in a.dirs:
        for p in sorted((ROOT / d).glob("*.cpp")) + sorted((ROOT / d).glob("*.h")):
            for length, line, name in functions(p):
                rows.append((length, f"{p.relative_to(ROOT)}:{line}", name))
    rows.sort(key=lambda r: (-r[0], r[1]))
    for length, where, name in rows[: a.top]:
        print(f"{length:5d}  {where}  {name}")
    if a.limit and rows and rows[0][0] > a.limit:
        over = sum(1 for r in rows if r[0] > a.limit)
        print(f"{over} function(s) over {a.limit} lines", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
