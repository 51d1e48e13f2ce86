"""hevo.Controller: loading and saving controller files, the tree, genomes read and set, and
the errors, whose messages are the command line's."""

import numpy as np
import pytest

import hevo


def test_load_save_round_trip(repo, tmp_path):
    original = hevo.Controller.load(repo / "controllers" / "solve_maze.json")
    path = tmp_path / "copy.json"
    original.save(path)
    again = hevo.Controller.load(path)
    assert again == original
    assert again.content_hash == original.content_hash
    assert hevo.Controller.from_json(original.to_json()) == original


def test_tree_and_genome_lengths(repo):
    controller = hevo.Controller.load(repo / "controllers" / "solve_maze.json")
    tree = controller.tree()
    assert tree["name"] == "solve_maze"
    assert tree["kind"] == "arbitrator"
    assert [child["name"] for child in tree["children"]] == [
        "follow_wall",
        "turn_left",
        "turn_right",
    ]
    assert controller.node_paths[0] == "solve_maze"
    assert "solve_maze/turn_left" in controller.node_paths
    for node in [tree, *tree["children"]]:
        assert controller.genome_length(node["path"]) == node["n_genes"]
        assert len(controller.genome(node["path"])) == node["n_genes"]
    assert controller.free_node is None
    assert controller.n_genes == 0


def test_genomes_read_and_set(repo):
    controller = hevo.Controller.load(repo / "controllers" / "follow_wall.json")
    genes = controller.genome()
    assert genes.dtype == np.float32
    changed = genes + np.float32(0.25)
    controller.set_genome(changed)
    np.testing.assert_array_equal(controller.genome(), changed)
    # The returned array is a copy: changing it changes nothing.
    controller.genome()[0] = 99.0
    np.testing.assert_array_equal(controller.genome(), changed)


def test_template_and_filled_copy(repo):
    complete = hevo.Controller.load(repo / "controllers" / "solve_maze.json")
    template = complete.without_genome("solve_maze")
    assert template.free_node == "solve_maze"
    assert template.n_genes == complete.genome_length("solve_maze")
    assert template.genome("solve_maze") is None
    filled = template.with_genome(complete.genome("solve_maze"))
    assert filled == complete
    # Any float dtype: float64 rounds to the same float32 genes.
    assert template.with_genome(complete.genome("solve_maze").astype(np.float64)) == complete
    assert template.with_genome(complete.genome("solve_maze").tolist()) == complete
    copy = hevo.Controller.load(repo / "controllers" / "solve_maze.json")
    copy.set_genome(complete.genome("solve_maze").astype(np.float64) + 1e-12, "solve_maze")
    assert copy == complete
    with pytest.raises(TypeError, match="float array"):
        template.with_genome(np.zeros(template.n_genes, dtype=np.int32))
    with pytest.raises(ValueError, match="1-D"):
        template.with_genome(np.zeros((1, template.n_genes)))


def test_bad_genomes_are_controller_errors(repo):
    controller = hevo.Controller.load(repo / "controllers" / "follow_wall.json")
    before = controller.genome()
    with pytest.raises(hevo.ControllerError, match="follow_wall"):
        controller.set_genome(np.zeros(3, dtype=np.float32))
    with pytest.raises(hevo.ControllerError):
        controller.set_genome(np.full(len(before), np.nan, dtype=np.float32))
    with pytest.raises(hevo.ControllerError, match=r"gene 0 is 10.5, outside \[-10, 10\]"):
        controller.set_genome(np.full(len(before), 10.5))
    np.testing.assert_array_equal(controller.genome(), before)
    with pytest.raises(hevo.ControllerError, match="no node 'nowhere'"):
        controller.genome("nowhere")
    assert issubclass(hevo.ControllerError, hevo.HevoError)


def test_file_errors_carry_the_command_lines_messages(tmp_path, hevo_cli):
    missing = tmp_path / "missing.json"
    broken = tmp_path / "broken.json"
    broken.write_text('{"schema": "hevo.controller/1"}')
    for path in (missing, broken):
        with pytest.raises(hevo.ControllerError) as raised:
            hevo.Controller.load(path)
        cli = hevo_cli("eval", path, "--task", "follow_wall", check=False)
        assert cli.returncode != 0
        assert cli.stderr.strip() == f"error: {raised.value}"
