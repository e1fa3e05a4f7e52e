"""The gap diagnosis's results file reruns as written (issue 34): every block of
docs/gap_results.md is rewritten by the command at its head, which bench/gap_results_rerun.py
checks (--dry-run: each bench reads its options and refuses what it cannot run) and runs.
Generator C is a stand-in file here: its commands are checked, not run (no test depends on
../shared)."""
import os
import re
import subprocess
import sys
import tempfile
import unittest

from test_cli import ROOT

TOOL = os.path.join(ROOT, "bench", "gap_results_rerun.py")
REFEREE = os.environ.get("BRAKEFIT_REFEREE_BIN",
                         os.path.join(ROOT, "build", "release", "bench", "gap_referee"))
BUILD = os.path.dirname(os.path.dirname(REFEREE))
HEAD = re.compile(r"<!-- written by `(.*?)` at commit (\S+) \((\d{4}-\d\d-\d\d), (\d+) min")


def tool(*args):
    return subprocess.run([sys.executable, TOOL, "--build", BUILD, *args], capture_output=True,
                          text=True, timeout=600)


def block(key, command, body="| a table |"):
    return (f"<!-- {key} begin -->\n<!-- written by `{command}` at commit 0000000 (2026-01-01, "
            f"0 min) -->\n\n{body}\n<!-- {key} end -->\n")


class ResultsRerun(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.gen_c = os.path.join(self.tmp.name, "gen_c.py")  # the commands' stand-in for C
        with open(self.gen_c, "w") as f:
            f.write("raise SystemExit('a stand-in: not run by a dry run')\n")

    def tearDown(self):
        self.tmp.cleanup()

    def write(self, text):
        path = os.path.join(self.tmp.name, "results.md")
        with open(path, "w") as f:
            f.write(text)
        return path

    def test_every_block_of_the_results_file_has_a_command_its_bench_accepts(self):
        results = os.path.join(ROOT, "docs", "gap_results.md")
        with open(results) as f:
            heads = len(HEAD.findall(f.read()))
        r = tool("--dry-run", "--gen-c", self.gen_c)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn(f"{heads} of {heads} blocks' commands check", r.stdout)
        self.assertGreater(heads, 30)
        listed = tool("--list")
        self.assertEqual(listed.returncode, 0, listed.stderr)
        self.assertIn(f"{heads} blocks, ", listed.stdout)

    def test_a_block_is_written_again_by_its_own_command_and_the_rest_kept(self):
        path = self.write("# Results\n\nWritten by hand, kept.\n\n" + block(
            "gap_referee roller A",
            f"build/release/bench/gap_referee --condition roller --generators A --crossed 0 "
            f"--trials 1 --trials-other 0 --calibrate 1 --misspecified 0 --threads 2 "
            f"--results {os.path.join(self.tmp.name, 'results.md')}") + "\nAfter, kept.\n")
        r = tool("--results", path)
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(path) as f:
            text = f.read()
        self.assertTrue(text.startswith("# Results\n\nWritten by hand, kept.\n"), text)
        self.assertTrue(text.endswith("\nAfter, kept.\n"), text)
        head = HEAD.search(text)
        self.assertIsNotNone(head, text)
        self.assertNotEqual(head.group(2), "0000000")  # the bench wrote its own head
        self.assertTrue(head.group(1).startswith(os.path.join(BUILD, "bench", "gap_referee")))
        self.assertNotIn("| a table |", text)
        self.assertIn("| roller | A | A | ", text)
        self.assertIn("[1/1] gap_referee roller A", r.stderr)

    def test_a_command_its_bench_refuses_fails_the_check_naming_the_block(self):
        path = self.write(block("gap_referee roller A",
                                "build/release/bench/gap_referee --condition roller --generators "
                                "A --trials abc --results RESULTS") + block(
            "gap_c_suite", "/usr/bin/python3 bench/gap_c_suite.py --seed 5,x --results RESULTS"))
        with open(path) as f:
            text = f.read().replace("RESULTS", path)
        with open(path, "w") as f:
            f.write(text)
        r = tool("--results", path, "--dry-run", "--gen-c", self.gen_c)
        self.assertEqual(r.returncode, 1, r.stderr)
        self.assertIn(f"{path}:1: block 'gap_referee roller A'", r.stderr)
        self.assertIn("--trials takes a whole number from 0, not 'abc'", r.stderr)
        self.assertIn("block 'gap_c_suite'", r.stderr)
        self.assertIn("--seed takes integers", r.stderr)
        self.assertIn("0 of 2 blocks' commands check", r.stdout)

    def test_a_block_its_command_would_not_write_is_refused_before_anything_runs(self):
        other = os.path.join(self.tmp.name, "other.md")
        path = self.write(
            block("gap_referee roller A", "build/release/bench/gap_referee --condition roller "
                  f"--generators A --trials 1 --calibrate 1 --results {other}") +
            block("gap_referee ground B", "build/release/bench/gap_referee --condition roller "
                  "--generators B --trials 1 --calibrate 1 --results RESULTS") +
            block("gap_many_runs", "python3 bench/gap_many_runs.py --sets 3"))
        with open(path) as f:
            text = f.read().replace("RESULTS", path)
        with open(path, "w") as f:
            f.write(text)
        r = tool("--results", path)
        self.assertEqual(r.returncode, 1, r.stderr)
        self.assertIn(f"block 'gap_referee roller A': its command writes {other}", r.stderr)
        self.assertIn("block 'gap_referee ground B': its command writes "
                      f"{path}, block 'gap_referee roller B'", r.stderr)
        self.assertIn("block 'gap_many_runs': its command writes no results file", r.stderr)
        self.assertNotIn("[1/", r.stderr)  # nothing ran
        self.assertFalse(os.path.exists(other))

    def test_a_table_outside_a_block_or_a_block_without_a_head_is_an_error(self):
        loose = self.write("<!-- written by `python3 bench/gap_many_runs.py` at commit abc "
                           "(2026-01-01, 1 min) -->\n")
        r = tool("--results", loose, "--list")
        self.assertNotEqual(r.returncode, 0)
        self.assertIn("outside a begin/end block", r.stderr)
        headless = self.write("<!-- gap_many_runs begin -->\n| a table |\n<!-- gap_many_runs end -->\n")
        r = tool("--results", headless, "--list")
        self.assertNotEqual(r.returncode, 0)
        self.assertIn(f"{headless}:1: block 'gap_many_runs' has no `written by` head", r.stderr)


if __name__ == "__main__":
    unittest.main()
