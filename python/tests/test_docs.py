"""The Python examples of docs/python.md and README.md run as written, so none can crash on a
reader again. Every ```python block of a document is one of two kinds:

- a call signature, `name(params) -> Type` and nothing else: its parameters (names, order,
  defaults) are checked against the module's own signature;
- code: the document's code blocks run in order in one Python process, sharing their names as
  a reader in a notebook would, in a temporary directory where the repository's input folders
  (controllers/, scenarios/, experiments/) are linked in, so every file a block writes lands
  in the temporary directory. A block whose first line is `# doc-test: needs cluster` runs
  against a master with two workers started by the test (its address in place of
  `http://master:50051`, its client token in HEVO_TOKEN).

No block is skipped: a block that is neither fails the test."""

import ast
import inspect
import json
import math
import os
import pathlib
import re
import subprocess
import sys

import pytest

import hevo
from conftest import CLIENT_TOKEN, cluster

REPO = pathlib.Path(__file__).resolve().parents[2]
DOCS = ["docs/python.md", "README.md"]
# What the documents read, linked into the directory the blocks run in.
INPUT_FOLDERS = ["controllers", "scenarios", "experiments"]
CLUSTER_MARK = "# doc-test: needs cluster"
PLACEHOLDER_URL = "http://master:50051"
SIGNATURE = re.compile(r"\s*([\w.]+)\((.*)\)\s*->\s*[^\n]+\s*", flags=re.S)
# The objects a signature block's leading name stands for.
SIGNATURE_ROOTS = {"hevo": hevo, "client": hevo.Client}


def python_blocks(doc):
    """(line of the block's first code line, code) for every ```python block of `doc`."""
    text = (REPO / doc).read_text()
    blocks = []
    for match in re.finditer(r"^```python\n(.*?)^```", text, flags=re.S | re.M):
        line = text.count("\n", 0, match.start(1)) + 1
        blocks.append((line, match.group(1)))
    return blocks


def is_signature(code):
    return SIGNATURE.fullmatch(code) is not None


def documented_parameters(code):
    """The parameters of a signature block as (name, default or inspect.Parameter.empty)."""
    name, params = SIGNATURE.fullmatch(code).groups()
    function = ast.parse(f"def f({params}): pass").body[0]
    args = function.args.args
    defaults = [inspect.Parameter.empty] * (len(args) - len(function.args.defaults))
    defaults += [ast.literal_eval(default) for default in function.args.defaults]
    return name, [(arg.arg, default) for arg, default in zip(args, defaults)]


def actual_parameters(name):
    root, *rest = name.split(".")
    target = SIGNATURE_ROOTS[root]
    for attribute in rest:
        target = getattr(target, attribute)
    parameters = inspect.signature(target).parameters.values()
    return [(p.name, p.default) for p in parameters if p.name not in ("self", "$self")]


ALL_BLOCKS = [(doc, line, code) for doc in DOCS for line, code in python_blocks(doc)]


def test_the_documents_have_python_blocks():
    # A renamed fence or a moved document would otherwise leave the tests below nothing to do.
    assert len(python_blocks("docs/python.md")) >= 7
    assert len(python_blocks("README.md")) >= 1


SIGNATURE_BLOCKS = [block for block in ALL_BLOCKS if is_signature(block[2])]


@pytest.mark.parametrize(
    "doc,line,code", SIGNATURE_BLOCKS, ids=[f"{doc}:{line}" for doc, line, _ in SIGNATURE_BLOCKS]
)
def test_signature_matches_the_module(doc, line, code):
    name, documented = documented_parameters(code)
    assert documented == actual_parameters(name), f"{doc}:{line}: {name}"


# Runs a document's code blocks in order in one namespace. Each block is compiled under the
# document's path with its own line numbers, so a traceback points at the document's line.
DRIVER = """
import json, sys
namespace = {"__name__": "__main__"}
for block in json.load(open(sys.argv[1])):
    print("doc-test: block at line", block["line"], flush=True)
    code = "\\n" * (block["line"] - 1) + block["code"]
    exec(compile(code, block["path"], "exec"), namespace)
print("doc-test: done", flush=True)
"""


def run_code_blocks(doc, directory, binaries):
    """Runs `doc`'s code blocks in `directory`; returns the completed process."""
    code_blocks = [(line, code) for line, code in python_blocks(doc) if not is_signature(code)]
    assert code_blocks, doc
    for folder in INPUT_FOLDERS:
        (directory / folder).symlink_to(REPO / folder, target_is_directory=True)
    needs_cluster = any(code.startswith(CLUSTER_MARK) for _, code in code_blocks)
    env = dict(os.environ)

    def run(url=None):
        blocks = []
        for line, code in code_blocks:
            if code.startswith(CLUSTER_MARK):
                assert PLACEHOLDER_URL in code, f"{doc}:{line}: marked, but no {PLACEHOLDER_URL}"
                code = code.replace(PLACEHOLDER_URL, url)
            blocks.append({"line": line, "code": code, "path": str(REPO / doc)})
        (directory / "blocks.json").write_text(json.dumps(blocks))
        return subprocess.run(
            [sys.executable, "-c", DRIVER, str(directory / "blocks.json")],
            cwd=directory, env=env, capture_output=True, text=True, timeout=600,
        )

    if not needs_cluster:
        completed = run()
    else:
        (directory / "cluster").mkdir()
        env["HEVO_TOKEN"] = CLIENT_TOKEN
        with cluster(binaries, directory / "cluster", workers=2) as running:
            completed = run(running.url)
    assert completed.returncode == 0, completed.stdout + completed.stderr
    output = completed.stdout.splitlines()
    ran = [int(text.split()[-1]) for text in output if text.startswith("doc-test: block")]
    assert ran == [line for line, _ in code_blocks]
    assert output[-1] == "doc-test: done"
    return completed


def test_python_md_runs(tmp_path, binaries):
    completed = run_code_blocks("docs/python.md", tmp_path, binaries)
    # "A first look": the trace's shapes, and its picture written where the block ran.
    output = completed.stdout.splitlines()
    poses = [text for text in output if text.startswith("(") and ", 3)" in text]
    assert poses and ", 2, 3)" in poses[0], completed.stdout
    assert (tmp_path / "maze.svg").stat().st_size > 1000
    # "A master": the fetched job's files.
    assert any((tmp_path / "runs").rglob("*.json")), completed.stdout


def test_readme_runs(tmp_path, binaries):
    completed = run_code_blocks("README.md", tmp_path, binaries)
    best_fitness, best_solve_rate = map(float, completed.stdout.splitlines()[-2].split())
    assert 0.0 <= best_solve_rate <= 1.0 and math.isfinite(best_fitness)
