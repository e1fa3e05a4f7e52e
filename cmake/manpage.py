#!/usr/bin/env python3
"""Writes a man page from a program's help text: help2man for NAME, SYNOPSIS, DESCRIPTION and
OPTIONS; this script adds every subcommand's usage and options (CLI11's `SUB --help`, recursively)
and the EXIT STATUS table parsed from the README, so neither can drift from the program.

usage: manpage.py BIN SECTION NAME INCLUDE README OUT.gz
"""
import gzip
import os
import re
import subprocess
import sys
import tempfile


def roff(text):
    """Plain text as roff: backslashes escaped, a leading control character neutralised."""
    text = text.replace("\\", "\\e")
    return "\\&" + text if text[:1] in (".", "'") else text


def option(text):
    return roff(text).replace("-", "\\-")


def parse_help(out):
    """CLI11 help: description, `Usage: ...`, then sections of `  name  description` entries."""
    desc, usage, sections, current = [], "", {}, None
    for line in out.splitlines():
        if line.startswith("Usage: "):
            usage = line[len("Usage: "):]
        elif not usage:
            if line.strip():
                desc.append(line.strip())
        elif re.match(r"^\S.*:$", line):
            current = sections.setdefault(line[:-1], [])
        elif current is not None and re.match(r"^  \S", line):
            m = re.match(r"^  (\S.*?)(?:\s{2,}(\S.*))?$", line)
            head, what = m.group(1), m.group(2) or ""
            if not what and " REQUIRED " in head:  # a full name column leaves one space
                head, what = head.split(" REQUIRED ", 1)
                head += " REQUIRED"
            current.append([head, what])
        elif current is not None and line.strip() and current:
            current[-1][1] = (current[-1][1] + " " + line.strip()).strip()
    return " ".join(desc), usage, sections


def subcommand_pages(binary, name, path):
    out = subprocess.run([binary, *path, "--help"], capture_output=True, text=True, check=True).stdout
    desc, usage, sections = parse_help(out)
    text = []
    if path:
        usage = re.sub(r"^\S+", name, usage)
        text += [f'.SS "{option(usage)}"', roff(desc) + "."]
        for title in ("Positionals", "Options"):
            for head, what in sections.get(title, []):
                if head.startswith("-h,--help"):
                    continue
                names, _, kind = head.partition(" ")
                text += [".TP", f"\\fB{option(names)}\\fR {roff(kind)}".rstrip(), roff(what) or "."]
    for sub, _ in sections.get("Subcommands", []):
        text += subcommand_pages(binary, name, path + [sub])
    return text


def exit_status(readme):
    """The README's `## Exit codes` table as a tagged list."""
    text, inside = [], False
    with open(readme, encoding="utf-8") as f:
        for line in f:
            if line.startswith("## "):
                inside = line.strip() == "## Exit codes"
            elif inside:
                m = re.match(r"^\| (\d+) \| (.*) \|$", line.strip())
                if m:
                    what = re.sub(r"`([^`]*)`", r"\\fB\1\\fR", roff(m.group(2)))
                    text += [".TP", f".B {m.group(1)}", what[0].upper() + what[1:] + "."]
    if not text:
        sys.exit(f"{readme}: no '## Exit codes' table")
    return text


def main():
    binary, section, name_line, include, readme, out = sys.argv[1:]
    name = os.path.basename(binary)
    extra = ["[EXIT STATUS]"] + exit_status(readme)
    commands = subcommand_pages(binary, name, [])
    if commands:
        extra = ["[COMMANDS]", f"Each command's options; \\fB{name}\\fR \\fICOMMAND\\fR "
                 "\\fB\\-\\-help\\fR prints them too."] + commands + extra
    with open(include, encoding="utf-8") as f:
        static = f.read()
    with tempfile.NamedTemporaryFile("w", suffix=".h2m", delete=False) as h2m:
        h2m.write(static + "\n".join(extra) + "\n")
    try:
        page = subprocess.run(["help2man", "--no-info", f"--section={section}", f"--name={name_line}",
                               f"--include={h2m.name}", binary],
                              capture_output=True, text=True, check=True).stdout
    finally:
        os.unlink(h2m.name)
    # Reproducible: no name and no time in the gzip header (lintian: gzip -n).
    with open(out, "wb") as raw, gzip.GzipFile(filename="", mode="wb", fileobj=raw, mtime=0,
                                               compresslevel=9) as gz:
        gz.write(page.encode("utf-8"))


if __name__ == "__main__":
    main()
