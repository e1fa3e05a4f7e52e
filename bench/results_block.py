"""A bench's table in its own block of a Markdown results file (docs/gap_results.md).

A block runs from `<!-- NAME begin -->` to `<!-- NAME end -->`; its first line says the command
that wrote it and the commit it ran at. Writing a block replaces the block of that name and leaves
the rest of the file as it was; a block not yet there is added at the file's end.
"""
import os
import subprocess


def source_commit(root):
    """The short commit of the tree at root (empty outside git)."""
    return subprocess.run(["git", "-C", root, "rev-parse", "--short", "HEAD"],
                          capture_output=True, text=True).stdout.strip()


def write_block(path, name, text):
    begin, end = f"<!-- {name} begin -->", f"<!-- {name} end -->"
    with open(path) as f:
        doc = f.read()
    block = f"{begin}\n{text}\n{end}"
    if begin in doc and end in doc:
        doc = doc[: doc.index(begin)] + block + doc[doc.index(end) + len(end):]
    else:
        doc = doc.rstrip("\n") + "\n\n" + block + "\n"
    with open(path, "w") as f:
        f.write(doc)


def writable(path):
    """A results file can be written there: it exists and is writable, or its folder is."""
    if os.path.exists(path):
        return os.access(path, os.W_OK)
    return os.access(os.path.dirname(os.path.abspath(path)), os.W_OK)
