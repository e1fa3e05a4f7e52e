#!/usr/bin/python3
"""Generator C's tyres as MF 6.1 property files: its TYRES table (each tyre's reference load FZ0
and longitudinal coefficients) read from its script without running it, each tyre written as
NAME.tir with FNOMIN and the coefficients, as a researcher who knows the tyre has its file.

    /usr/bin/python3 bench/gen_c_tyres.py ../shared/gapgen/gen_c.py OUTDIR
"""
import ast
import os
import sys


def c_tyres(gen_c):
    """Generator C's TYRES table, evaluated alone from its script (the script is not run)."""
    with open(gen_c) as f:
        tree = ast.parse(f.read(), gen_c)
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", "") == "TYRES"
                                                for t in node.targets):
            space = {}
            exec(compile(ast.Module([node], []), gen_c, "exec"), {"__builtins__": {"dict": dict}},
                 space)
            return space["TYRES"]
    sys.exit(f"gen_c_tyres: {gen_c} has no TYRES table (the tyres' coefficients are read there)")


def write_tir(path, name, coefficients):
    """An MF 6.1 property file with the tyre's reference load and longitudinal coefficients."""
    lines = ["[MDI_HEADER]", "FILE_TYPE = 'tir'", "FILE_VERSION = 3.0",
             f"$ generator C's tyre {name}, written by bench/gen_c_tyres.py",
             "[VERTICAL]", f"FNOMIN = {coefficients['FZ0']!r}", "[LONGITUDINAL_COEFFICIENTS]"]
    lines += [f"{k} = {v!r}" for k, v in coefficients.items() if k != "FZ0"]
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def write_all(gen_c, out):
    os.makedirs(out, exist_ok=True)
    for name, coefficients in c_tyres(gen_c).items():
        write_tir(os.path.join(out, name + ".tir"), name, coefficients)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__.strip().splitlines()[-1].strip())
    write_all(sys.argv[1], sys.argv[2])
