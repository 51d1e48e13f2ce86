"""hevo.trace: one sample cycle by cycle, the same as `hevo replay` draws and tabulates."""

import numpy as np
import pytest

import hevo


def test_arrays_describe_every_cycle(repo):
    controller = hevo.Controller.load(repo / "controllers" / "solve_maze.json")
    trace = hevo.trace(controller, hevo.Task("solve_maze"), seed=4, variant=2)
    n = len(trace)
    assert n == trace.outcome["cycles"] > 0
    assert trace.variant == 2 and trace.seed == 4
    assert trace.robots[0] == "robot"
    assert trace.poses.shape == (n, len(trace.robots), 3)
    assert trace.inputs.shape == (n, 17)
    assert len(trace.input_names) == 17
    # The range-and-bearing board and the item sensor come last; the maze's robot carries
    # neither.
    assert trace.input_names[6:] == [
        "near_robot", "rab_front", "rab_left", "rab_back", "rab_right", "rab_count",
        "items_front", "items_left", "items_back", "items_right", "items_carrying"]
    assert (trace.inputs[:, 7:] == 0).all()
    assert trace.outputs.shape == (n, 2)
    assert ((trace.outputs >= 0) & (trace.outputs <= 1)).all()
    assert ((trace.inputs >= 0) & (trace.inputs <= 1)).all()
    assert trace.active_path.shape == (n, 2)
    assert (trace.active_path[:, 0] == 0).all()
    np.testing.assert_array_equal(trace.active_node, trace.active_path[:, -1])
    used = {trace.node_paths[i] for i in np.unique(trace.active_node)}
    assert used <= set(controller.node_paths[1:])
    assert trace.collided.dtype == np.bool_
    assert trace.walls.shape[1] == 5 and len(trace.walls) > 0
    # The robot moves.
    assert np.ptp(trace.poses[:, 0, 0]) > 0.1
    follow = hevo.trace(
        hevo.Controller.load(repo / "controllers" / "follow_wall.json"), hevo.Task("follow_wall")
    )
    assert follow.robots == ["robot"]
    assert follow.poses.shape == (len(follow), 1, 3)


def test_the_rescue_has_two_robots(repo):
    controller = hevo.Controller.load(repo / "controllers" / "rescue.json")
    trace = hevo.trace(controller, hevo.Task("rescue", max_cycles=50), seed=1)
    assert trace.robots == ["robot", "teammate"]
    assert trace.poses.shape == (len(trace), 2, 3)
    assert not np.isnan(trace.poses).any()


def test_a_swarm_has_every_robot(repo):
    controller = hevo.Controller.load(repo / "controllers" / "aggregation.json")
    task = hevo.Task(repo / "scenarios" / "swarm" / "aggregation.toml", max_cycles=30)
    trace = hevo.trace(controller, task, seed=3)
    assert trace.robots == ["robot"] + [f"swarm_{i}" for i in range(9)]
    assert trace.poses.shape == (len(trace), 10, 3)
    assert not np.isnan(trace.poses).any()
    # Every robot runs its own copy of the controller: the team moves.
    assert (np.ptp(trace.poses[:, 1:, :2], axis=0).max(axis=1) > 0).all()
    header = trace.to_csv().splitlines()[0].split(",")
    assert header[-3:] == ["swarm_8_x", "swarm_8_y", "swarm_8_heading"]


def test_picture_and_tables_are_the_command_lines(repo, tmp_path, hevo_cli):
    path = repo / "controllers" / "solve_maze.json"
    controller = hevo.Controller.load(path)
    trace = hevo.trace(controller, hevo.Task("solve_maze"), seed=4, variant=2)
    svg, csv, js = tmp_path / "cli.svg", tmp_path / "cli.csv", tmp_path / "cli.json"
    hevo_cli(
        "replay", path, "--task", "solve_maze", "--seed", 4, "--light-config", 2,
        "--rays", "60,150", "--out", svg, "--trace-out", csv,
    )
    hevo_cli(
        "replay", path, "--task", "solve_maze", "--seed", 4, "--light-config", 2,
        "--trace-out", js,
    )
    assert trace.to_svg(rays=[60, 150]) == svg.read_text()
    assert trace.to_csv() == csv.read_text()
    assert trace.to_json() == js.read_text()
    lines = csv.read_text().splitlines()
    assert len(lines) == len(trace) + 1
    header = lines[0].split(",")
    first = dict(zip(header, lines[1].split(",")))
    assert np.float32(first["robot_x"]) == trace.poses[0, 0, 0]
    assert np.float32(first["wheel_right"]) == trace.outputs[0, 1]
    assert first["active_node"] == trace.node_paths[trace.active_node[0]]
    written = tmp_path / "python.svg"
    trace.to_svg(written, rays=[60, 150])
    assert written.read_text() == svg.read_text()


def test_errors(repo):
    complete = hevo.Controller.load(repo / "controllers" / "follow_wall.json")
    with pytest.raises(hevo.ControllerError, match="has no genome"):
        hevo.trace(complete.without_genome(), hevo.Task("follow_wall"))
    with pytest.raises(hevo.ConfigError, match="out of range"):
        hevo.trace(complete, hevo.Task("solve_maze"), variant=4)
