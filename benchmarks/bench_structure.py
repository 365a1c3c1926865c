"""Structure of the code base: validation share per package, long functions, policy plugin size.

Run from the repository root: ``python -m benchmarks.bench_structure [ROOT]``.

Validation lines: code lines (no blanks, comments, docstrings) of
  - the module lerobot_forcemap/_validation.py;
  - statements calling a checker (check_*, fail, _check*, _require*, require_*, validate*), whole statement;
  - `if ...: raise ValueError/TypeError(...)` blocks whose body is only a raise (the if and the raise);
  - bare `raise ValueError(...)` statements.
"""

import ast
import io
import sys
import tokenize
from pathlib import Path

ROOT = Path(sys.argv[1] if len(sys.argv) > 1 else ".")
PACKAGES = [
    "lerobot_forcemap",
    "lerobot_policy_forcemap",
    "lerobot_env_forcemap",
    "lerobot_robot_forcemap",
    "experiments",
    "benchmarks",
]
CHECK_PREFIXES = ("check_", "fail", "_check", "_require", "validate", "_validate", "require_")


def code_lines(src: str) -> set[int]:
    lines = set()
    tree = ast.parse(src)
    doc = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            body = node.body
            if (
                body
                and isinstance(body[0], ast.Expr)
                and isinstance(getattr(body[0], "value", None), ast.Constant)
                and isinstance(body[0].value.value, str)
            ):
                doc.update(range(body[0].lineno, body[0].end_lineno + 1))
    for tok in tokenize.generate_tokens(io.StringIO(src).readline):
        if tok.type in (
            tokenize.COMMENT,
            tokenize.NL,
            tokenize.NEWLINE,
            tokenize.INDENT,
            tokenize.DEDENT,
            tokenize.ENDMARKER,
        ):
            continue
        for ln in range(tok.start[0], tok.end[0] + 1):
            lines.add(ln)
    return lines - doc


def _name(call: ast.Call) -> str:
    f = call.func
    return f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else ""


def _is_raise_value(node) -> bool:
    if not isinstance(node, ast.Raise) or node.exc is None:
        return False
    exc = node.exc.func if isinstance(node.exc, ast.Call) else node.exc
    name = exc.id if isinstance(exc, ast.Name) else getattr(exc, "attr", "")
    return name in ("ValueError", "TypeError")


def validation_lines(src: str) -> set[int]:
    tree = ast.parse(src)
    out: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.stmt) and not isinstance(
            node, (ast.FunctionDef, ast.ClassDef, ast.If, ast.For, ast.While, ast.With, ast.Try)
        ):
            calls = [c for c in ast.walk(node) if isinstance(c, ast.Call)]
            if any(_name(c).startswith(CHECK_PREFIXES) for c in calls):
                out.update(range(node.lineno, node.end_lineno + 1))
        if _is_raise_value(node):
            out.update(range(node.lineno, node.end_lineno + 1))
        if (
            isinstance(node, ast.If)
            and node.body
            and all(_is_raise_value(b) for b in node.body)
            and not node.orelse
        ):
            out.update(range(node.lineno, node.test.end_lineno + 1))
    return out


def main() -> None:
    long_funcs = []
    print(f"{'package':28} {'code lines':>10} {'validation':>10} {'share':>6}")
    for pkg in PACKAGES:
        total = val = 0
        for f in sorted((ROOT / pkg).rglob("*.py")):
            src = f.read_text()
            cl = code_lines(src)
            total += len(cl)
            if f.name == "_validation.py":
                val += len(cl)
            else:
                val += len(validation_lines(src) & cl)
            for n in ast.walk(ast.parse(src)):
                if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    length = n.end_lineno - n.lineno + 1
                    if length > 60:
                        long_funcs.append((length, f"{f.relative_to(ROOT)}:{n.lineno} {n.name}"))
        if total:
            print(f"{pkg:28} {total:>10} {val:>10} {100 * val / total:>5.1f}%")
    print("\nfunctions over 60 lines:")
    for length, where in sorted(long_funcs, reverse=True):
        print(f"  {length:4d}  {where}")
    plugin = sum(len(p.read_text().splitlines()) for p in (ROOT / "lerobot_policy_forcemap").glob("*.py"))
    print(f"\npolicy plugin: {plugin} lines (wc -l)")


if __name__ == "__main__":
    main()
