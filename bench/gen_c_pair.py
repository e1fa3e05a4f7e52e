#!/usr/bin/python3
"""Two of generator C's effects in one set, made by generator C's own code.

    gen_c_pair.py GEN_C_SCRIPT OUT --bench ground --effects A,B --magnitude X --seed N

gen_c.py injects one effect a set: its run() switches each effect on where the effect's name
compares equal to the one asked for, and gives it the set's one magnitude. Asked for a name that
compares equal to both A and B, the same run() switches on both, each through its own law and
at the same magnitude X (so only effects whose ranges share X make a pair). Nothing of the
physics is written here: the set is C's one_set() with that name. truth.json says "A+B".
"""
import argparse
import importlib.util
import sys


class BothEffects(str):
    """An effect name equal to each of two: run()'s `effect == "..."` switches both on."""

    def __new__(cls, a, b):
        name = super().__new__(cls, a + "+" + b)
        name.names = (a, b)
        return name

    def __eq__(self, other):
        return other in self.names

    def __ne__(self, other):
        return not self.__eq__(other)

    __hash__ = str.__hash__


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("script", help="generator C's gen_c.py")
    ap.add_argument("out")
    ap.add_argument("--bench", choices=["roller", "ground"], required=True)
    ap.add_argument("--effects", required=True, help="two effect names, A,B")
    ap.add_argument("--magnitude", type=float, required=True)
    ap.add_argument("--seed", type=int, required=True)
    a = ap.parse_args()
    names = a.effects.split(",")
    if len(names) != 2 or names[0] == names[1]:
        ap.error("--effects takes two different effect names, A,B")
    spec = importlib.util.spec_from_file_location("gen_c", a.script)
    if spec is None or spec.loader is None:
        sys.exit(f"gen_c_pair.py: cannot load {a.script}")
    gen_c = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen_c)
    known = gen_c.GROUND_EFFECTS if a.bench == "ground" else gen_c.ROLLER_EFFECTS
    for n in names:
        if n not in known or n == "none":
            ap.error(f"generator C does not inject {n} on the {a.bench}")
    gen_c.one_set(a.out, a.bench, BothEffects(*names), a.magnitude, a.seed)


if __name__ == "__main__":
    main()
