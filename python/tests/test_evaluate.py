"""hevo.evaluate: the numbers `hevo eval --json` prints, bit for bit, for every genome; the
same on any number of threads; genomes of any float dtype, clipped or refused naming row and
gene; each sample's outcome as arrays; the errors; and 10,000 genomes at once."""

import json
import math

import numpy as np
import pytest

import hevo


def perturbed(genes, n, seed):
    """`n` copies of `genes`, each gene moved by up to 0.5 and kept in a gene's range [-10, 10]."""
    rng = np.random.default_rng(seed)
    moved = genes[None, :] + rng.uniform(-0.5, 0.5, size=(n, len(genes)))
    return np.clip(moved, -10, 10).astype(np.float32)


def cli_report(hevo_cli, tmp_path, controller, task_flag, samples, seed):
    path = tmp_path / f"{controller.content_hash}.json"
    controller.save(path)
    out = hevo_cli(
        "eval", path, "--task", task_flag, "--samples", samples, "--seed", seed, "--json"
    )
    return json.loads(out.stdout)


def same(a, b):
    """Equal as floats, bit for bit (NaN for a phase no sample reached is `null` in JSON)."""
    if b is None:
        return math.isnan(a)
    return float(a) == float(b)


def check_against_cli(hevo_cli, tmp_path, template, genomes, task, task_flag, samples, seed):
    result = hevo.evaluate(template, genomes, task, samples=samples, seed=seed)
    assert len(result) == len(genomes)
    for i, genes in enumerate(genomes):
        report = cli_report(hevo_cli, tmp_path, template.with_genome(genes), task_flag, samples, seed)
        assert result.samples == report["samples"]
        assert same(result.fitness[i], report["mean_fitness"])
        assert same(result.solve_rate[i], report["solve_rate"])
        assert same(result.collision_rate[i], report["collision_rate"])
        assert same(result.mean_cycles[i], report["mean_cycles"])
        variants = report.get("per_variant", [])
        assert result.per_variant.shape == (len(genomes), len(variants))
        for v, variant in enumerate(variants):
            assert same(result.per_variant[i, v], variant["solve_rate"])
        if "stages" in report:
            stages = report["stages"]
            expected = [stages["exited_room"], stages["reached_teammate"], stages["returned"]]
        else:
            expected = [stage["share"] for stage in report.get("per_stage", [])]
            assert result.stage_names == [stage["stage"] for stage in report.get("per_stage", [])]
        assert [float(x) for x in result.per_stage[i]] == expected
        phases = [phase["right_choice"] for phase in report.get("per_phase", [])]
        assert len(result.per_phase[i]) >= len(phases)
        for p, share in enumerate(phases):
            assert same(result.per_phase[i, p], share)
    return result


def test_equal_to_the_cli_on_the_maze_arbitrator(repo, tmp_path, hevo_cli):
    complete = hevo.Controller.load(repo / "controllers" / "solve_maze.json")
    template = complete.without_genome("solve_maze")
    genomes = perturbed(complete.genome("solve_maze"), 3, seed=1)
    genomes[0] = complete.genome("solve_maze")
    result = check_against_cli(
        hevo_cli, tmp_path, template, genomes, hevo.Task("solve_maze"), "solve_maze", 2, 7
    )
    assert len(result.variant_names) == 4 and result.per_variant.shape == (3, 4)
    # The shipped controller solves the maze.
    assert result.solve_rate[0] > 0.5


def test_equal_to_the_cli_on_a_scenario_file(repo, tmp_path, hevo_cli):
    path = str(repo / "scenarios" / "examples" / "t_maze.toml")
    task = hevo.Task(path)
    complete = hevo.bench_controller(task, seed=4)
    template = complete.without_genome()
    genomes = perturbed(complete.genome(), 2, seed=2)
    check_against_cli(hevo_cli, tmp_path, template, genomes, task, path, 3, 11)


def test_threads_do_not_change_results(repo):
    complete = hevo.Controller.load(repo / "controllers" / "follow_wall.json")
    template = complete.without_genome()
    genomes = perturbed(complete.genome(), 5, seed=3)
    task = hevo.Task("follow_wall", max_cycles=120)
    one = hevo.evaluate(template, genomes, task, samples=3, seed=5, threads=1)
    three = hevo.evaluate(template, genomes, task, samples=3, seed=5, threads=3)
    for name in ("fitness", "solve_rate", "collision_rate", "mean_cycles"):
        np.testing.assert_array_equal(getattr(one, name), getattr(three, name))
    other_seed = hevo.evaluate(template, genomes, task, samples=3, seed=6, threads=1)
    assert not np.array_equal(one.mean_cycles, other_seed.mean_cycles) or not np.array_equal(
        one.fitness, other_seed.fitness
    )


def test_a_template_reading_a_sensor_the_robot_lacks(repo, tmp_path):
    text = (repo / "scenarios" / "examples" / "t_maze.toml").read_text()
    ir_only = tmp_path / "ir_only.toml"
    ir_only.write_text(text.replace("max_cycles = 500", 'sensors = ["ir"]\nmax_cycles = 500', 1))
    task = hevo.Task(str(ir_only))
    maze = hevo.Controller.load(repo / "controllers" / "solve_maze.json")
    template = maze.without_genome()
    genomes = np.zeros((1, template.n_genes), dtype=np.float32)
    with pytest.raises(hevo.ControllerError, match="reads 'light'.*it has ir"):
        hevo.evaluate(template, genomes, task)
    with pytest.raises(hevo.ControllerError, match="reads 'light'"):
        hevo.trace(maze, task)


def test_bad_inputs(repo):
    complete = hevo.Controller.load(repo / "controllers" / "follow_wall.json")
    template = complete.without_genome()
    task = hevo.Task("follow_wall", max_cycles=20)
    with pytest.raises(hevo.ControllerError, match="no free node"):
        hevo.evaluate(complete, np.zeros((1, 3), dtype=np.float32), task)
    with pytest.raises(ValueError, match="takes"):
        hevo.evaluate(template, np.zeros((2, template.n_genes + 1), dtype=np.float32), task)
    with pytest.raises(ValueError, match="samples"):
        hevo.evaluate(template, np.zeros((1, template.n_genes), dtype=np.float32), task, samples=0)
    with pytest.raises(TypeError, match="float array.*int64"):
        hevo.evaluate(template, np.zeros((1, template.n_genes), dtype=np.int64), task)
    with pytest.raises(ValueError, match="2-D"):
        hevo.evaluate(template, np.zeros(template.n_genes), task)
    nan = np.full((1, template.n_genes), np.nan, dtype=np.float32)
    with pytest.raises(hevo.ControllerError):
        hevo.evaluate(template, nan, task)
    empty = hevo.evaluate(template, np.zeros((0, template.n_genes), dtype=np.float32), task)
    assert len(empty) == 0


def test_ten_thousand_genomes_keep_only_their_result_arrays(repo):
    complete = hevo.Controller.load(repo / "controllers" / "follow_wall.json")
    template = complete.without_genome()
    genomes = perturbed(complete.genome(), 10_000, seed=4)
    task = hevo.Task("follow_wall", max_cycles=3)
    result = hevo.evaluate(template, genomes, task, samples=1, seed=1)
    assert result.fitness.shape == (10_000,)
    assert result.samples == 1
    # Chunks of genomes are reduced in order: the last chunk's rows are the last genomes'.
    tail = hevo.evaluate(template, genomes[-3:], task, samples=1, seed=1)
    np.testing.assert_array_equal(result.fitness[-3:], tail.fitness)


ARRAYS = (
    "fitness", "solve_rate", "collision_rate", "mean_cycles", "per_variant", "per_stage",
    "per_phase", "descriptor", "sample_fitness", "sample_solved", "sample_collided",
    "sample_cycles", "sample_stage", "sample_variant", "sample_ending", "sample_descriptor",
    "sample_seeds",
)


def assert_same_evaluation(a, b):
    """Every array of two evaluations equal bit for bit (NaN where the other has NaN)."""
    for name in ARRAYS:
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and x.shape == y.shape, name
        assert x.tobytes() == y.tobytes(), name
    names = ("variant_names", "stage_names", "phase_names", "descriptor_names", "ending_names",
             "samples")
    assert [getattr(a, name) for name in names] == [getattr(b, name) for name in names]


def maze_setup(repo):
    complete = hevo.Controller.load(repo / "controllers" / "solve_maze.json")
    return complete, complete.without_genome("solve_maze"), hevo.Task("solve_maze", max_cycles=150)


def test_gene_range():
    assert hevo.GENE_RANGE == (-10.0, 10.0)


def test_float64_rounds_to_float32_and_other_float_dtypes(repo):
    complete, template, task = maze_setup(repo)
    rng = np.random.default_rng(5)
    genomes = complete.genome("solve_maze")[None, :] + rng.normal(0, 0.3, (3, template.n_genes))
    genomes = np.clip(genomes, -10, 10)
    assert genomes.dtype == np.float64
    as_float32 = hevo.evaluate(template, genomes.astype(np.float32), task, samples=2, seed=3)
    assert_same_evaluation(hevo.evaluate(template, genomes, task, samples=2, seed=3), as_float32)
    # A list of lists, as numpy.asarray makes of it: float64.
    assert_same_evaluation(
        hevo.evaluate(template, genomes.tolist(), task, samples=2, seed=3), as_float32)
    # float16 converts exactly; a non-contiguous view reads the same genes.
    half = genomes.astype(np.float16)
    assert_same_evaluation(
        hevo.evaluate(template, half, task, samples=2, seed=3),
        hevo.evaluate(template, half.astype(np.float32), task, samples=2, seed=3),
    )
    wide = np.repeat(genomes, 2, axis=1)[:, ::2]
    assert not wide.flags["C_CONTIGUOUS"]
    assert_same_evaluation(hevo.evaluate(template, wide, task, samples=2, seed=3), as_float32)


def test_out_of_range_genes_are_refused_naming_row_and_gene_or_clipped(repo):
    complete, template, task = maze_setup(repo)
    genomes = np.tile(complete.genome("solve_maze").astype(np.float64), (4, 1))
    genomes[2, 9] = -10.19458
    with pytest.raises(hevo.ControllerError) as refused:
        hevo.evaluate(template, genomes, task, samples=1)
    message = str(refused.value)
    assert "genomes[2, 9]" in message and "row 2" in message and "gene 9" in message
    assert "-10.19458" in message and "[-10, 10]" in message and "clip=True" in message
    clipped = hevo.evaluate(template, genomes, task, samples=2, seed=1, clip=True)
    assert_same_evaluation(
        clipped, hevo.evaluate(template, np.clip(genomes, -10, 10), task, samples=2, seed=1))
    # Far beyond float32's range, too.
    genomes[2, 9] = 1e300
    assert_same_evaluation(
        hevo.evaluate(template, genomes, task, samples=2, seed=1, clip=True),
        hevo.evaluate(template, np.clip(genomes, -10, 10), task, samples=2, seed=1),
    )
    with pytest.raises(hevo.ControllerError, match=r"genomes\[2, 9\].* is 1e300, outside"):
        hevo.evaluate(template, genomes, task, samples=1)
    genomes[2, 9] = 0.0
    for bad in (np.nan, np.inf, -np.inf):
        genomes[3, 0] = bad
        for clip in (False, True):
            with pytest.raises(hevo.ControllerError, match=r"genomes\[3, 0\].*row 3.*gene 0.*finite"):
                hevo.evaluate(template, genomes, task, samples=1, clip=clip)


def test_per_sample_outcomes(repo):
    complete, template, task = maze_setup(repo)
    genomes = np.tile(complete.genome("solve_maze"), (2, 1))
    genomes[1] = perturbed(complete.genome("solve_maze"), 1, seed=9)[0]
    result = hevo.evaluate(template, genomes, task, samples=2, seed=4)
    n_samples = result.samples
    assert n_samples == 2 * task.n_variants
    for name, dtype in (
        ("sample_fitness", np.float32), ("sample_solved", np.bool_),
        ("sample_collided", np.bool_), ("sample_cycles", np.uint32),
        ("sample_stage", np.uint8), ("sample_variant", np.uint32),
        ("sample_ending", np.uint8),
    ):
        array = getattr(result, name)
        assert array.shape == (2, n_samples) and array.dtype == dtype, name
    assert result.sample_seeds.shape == (n_samples,) and result.sample_seeds.dtype == np.uint64
    # The per-genome numbers are these samples' means.
    np.testing.assert_allclose(result.sample_fitness.mean(axis=1, dtype=np.float64), result.fitness, rtol=1e-6)
    np.testing.assert_allclose(result.sample_solved.mean(axis=1), result.solve_rate)
    np.testing.assert_allclose(result.sample_collided.mean(axis=1), result.collision_rate)
    np.testing.assert_allclose(result.sample_cycles.mean(axis=1), result.mean_cycles)
    assert set(result.sample_variant[0]) == set(range(task.n_variants))
    # The behaviour descriptor: the maze's default, where the robot ended; per genome the
    # samples' mean (summed in order in float64, as the runner tells a strategy).
    assert result.descriptor_names == ["final.x", "final.y"]
    assert result.ending_names == ["solved", "collision", "wrong_branch", "timeout"]
    assert result.sample_descriptor.shape == (2, n_samples, 2)
    assert result.sample_descriptor.dtype == np.float32
    assert result.descriptor.shape == (2, 2) and result.descriptor.dtype == np.float64
    for i in range(2):
        for d in range(2):
            total = 0.0
            for value in result.sample_descriptor[i, :, d]:
                total += float(value)
            assert result.descriptor[i, d] == total / n_samples
    # A solved sample, and only one, ends as solved.
    solved_code = result.ending_names.index("solved")
    np.testing.assert_array_equal(result.sample_ending == solved_code, result.sample_solved)
    # Each column is the sample `hevo.trace` replays from its seed and variant.
    for i, genes in enumerate(genomes):
        controller = template.with_genome(genes)
        for j in (0, n_samples - 1):
            trace = hevo.trace(controller, task, seed=int(result.sample_seeds[j]),
                               variant=int(result.sample_variant[i, j]))
            outcome = trace.outcome
            assert np.float32(outcome["fitness"]) == result.sample_fitness[i, j]
            assert outcome["solved"] == result.sample_solved[i, j]
            assert outcome["collided"] == result.sample_collided[i, j]
            assert outcome["cycles"] == result.sample_cycles[i, j]
            assert outcome["stage"] == result.sample_stage[i, j]
            assert outcome["ending"] == result.ending_names[result.sample_ending[i, j]]
            assert [np.float32(v) for v in outcome["descriptor"]] == list(result.sample_descriptor[i, j])
