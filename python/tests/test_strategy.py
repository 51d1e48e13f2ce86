"""hevo.Strategy: hevo's algorithms in the ask/tell style over numpy. The same seed asks for the
same genomes; a saved state resumed continues bit for bit as the uninterrupted strategy; fitness
and descriptors of any float dtype are taken, bad ones refused naming the row; settings are an
experiment file's `[evolution]` table, with its keys, defaults and messages."""

import json
import re

import numpy as np
import pytest

import hevo

# Small settings for each algorithm, so that many generations take little time.
ALGORITHMS = {
    "ga": dict(population=20, elites=4),
    "cmaes": dict(population=12, initial_sigma=2.0),
    # Novelty blended with fitness, so that it too approaches the sphere's optimum.
    "novelty": dict(population=20, elites=4, novelty_neighbours=5, novelty_archive_size=30,
                    novelty_fitness_weight=0.8),
}


def sphere(genomes):
    """Larger is better: minus the squared distance to every gene = 3."""
    return -((genomes - 3.0) ** 2).sum(axis=1)


def step(strategy, generations, dtype=np.float64):
    """Asks, scores on the sphere (the genes as descriptors) and tells, `generations` times;
    every genome asked for, in order."""
    asked = []
    for _ in range(generations):
        genomes = strategy.ask()
        asked.append(genomes)
        strategy.tell(sphere(genomes).astype(dtype), descriptors=genomes.astype(dtype))
    return asked


@pytest.mark.parametrize("algorithm", sorted(ALGORITHMS))
def test_the_same_seed_asks_for_the_same_genomes(algorithm):
    settings = ALGORITHMS[algorithm]
    a = hevo.Strategy(algorithm, n_genes=6, seed=7, **settings)
    b = hevo.Strategy(algorithm, n_genes=6, seed=7, **settings)
    c = hevo.Strategy(algorithm, n_genes=6, seed=8, **settings)
    assert a.algorithm == algorithm
    assert a.best is None and a.generation == 0
    first = a.ask()
    assert first.dtype == np.float64 and first.shape == (a.ask().shape[0], 6)
    # Each gene is a float32 value exactly: what hevo.evaluate evaluates.
    assert np.array_equal(first.astype(np.float32).astype(np.float64), first)
    assert np.array_equal(a.ask(), first), "asking again before telling gives the same genomes"
    assert not np.array_equal(c.ask(), first), "another seed, other genomes"
    for x, y in zip(step(a, 5), step(b, 5)):
        assert np.array_equal(x, y)
    assert a.generation == 5
    genome, fitness = a.best
    assert genome.shape == (6,) and isinstance(fitness, float)
    assert np.array_equal(genome, b.best[0]) and fitness == b.best[1]


@pytest.mark.parametrize("algorithm", sorted(ALGORITHMS))
def test_every_algorithm_improves_the_sphere(algorithm):
    strategy = hevo.Strategy(algorithm, n_genes=8, seed=5, **ALGORITHMS[algorithm])
    first = sphere(strategy.ask()).max()
    step(strategy, 60)
    genome, fitness = strategy.best
    assert first < -20.0
    assert fitness > -1.0, (algorithm, fitness)
    # The best's fitness is the one it was told with.
    assert fitness == pytest.approx(sphere(genome[None, :])[0], rel=1e-12)


@pytest.mark.parametrize("algorithm", sorted(ALGORITHMS))
def test_a_saved_strategy_resumes_bit_for_bit(algorithm):
    settings = ALGORITHMS[algorithm]
    straight = hevo.Strategy(algorithm, n_genes=5, seed=11, **settings)
    step(straight, 7)
    first = hevo.Strategy(algorithm, n_genes=5, seed=11, **settings)
    step(first, 3)
    saved = first.state()
    assert isinstance(saved, bytes)
    assert json.loads(saved)["strategy"]["algorithm"] == algorithm
    del first
    resumed = hevo.Strategy.from_state(saved)
    assert resumed.generation == 3 and resumed.algorithm == algorithm
    assert resumed.settings() == dict(settings, algorithm=algorithm)
    # From str as from bytes.
    assert hevo.Strategy.from_state(saved.decode()).state() == saved
    step(resumed, 4)
    assert np.array_equal(resumed.ask(), straight.ask())
    assert np.array_equal(resumed.best[0], straight.best[0])
    assert resumed.best[1] == straight.best[1]
    assert resumed.state() == straight.state()


def test_fitness_of_any_float_dtype_is_told_as_float64():
    settings = ALGORITHMS["cmaes"]
    runs = {}
    for dtype in (np.float64, np.float32, np.float16):
        strategy = hevo.Strategy("cmaes", n_genes=3, seed=2, **settings)
        for _ in range(3):
            genomes = strategy.ask()
            # Values a float16 holds exactly, so every dtype tells the same numbers.
            fitness = -np.round(((genomes - 1.0) ** 2).sum(axis=1))
            strategy.tell(fitness.astype(dtype))
        runs[dtype] = strategy.state()
    assert runs[np.float64] == runs[np.float32] == runs[np.float16]
    # A list is taken too; integers are not floats.
    strategy = hevo.Strategy("ga", n_genes=2, population=4, elites=2)
    strategy.tell([0.5, 1.0, -1.0, 2.0])
    with pytest.raises(TypeError, match="fitness must be a float array"):
        strategy.tell(np.arange(4))


def test_bad_results_are_refused_naming_the_row_and_change_nothing():
    strategy = hevo.Strategy("novelty", n_genes=3, seed=4, population=8, elites=2)
    step(strategy, 1)
    before = strategy.state()
    n = strategy.ask().shape[0]
    fitness = np.zeros(n)
    with pytest.raises(ValueError, match=r"fitness has 7 value\(s\) for the 8 genomes ask\(\) gave"):
        strategy.tell(fitness[:-1])
    with pytest.raises(ValueError, match=r"fitness must be 1-D, got shape \[8, 1\]"):
        strategy.tell(fitness[:, None])
    fitness[5] = np.nan
    with pytest.raises(ValueError, match=r"fitness\[5\] \(row 5 of the batch\) is NaN: fitness must be finite"):
        strategy.tell(fitness)
    fitness[5] = 0.0
    descriptors = np.zeros((n, 2))
    descriptors[3, 1] = -np.inf
    with pytest.raises(ValueError, match=r"descriptors\[3, 1\] \(row 3 of the batch\) is -inf"):
        strategy.tell(fitness, descriptors)
    with pytest.raises(ValueError, match=r"descriptors has 2 row\(s\) for the 8 genomes"):
        strategy.tell(fitness, np.zeros((2, 2)))
    assert strategy.state() == before
    strategy.tell(fitness, np.zeros((n, 3)))
    assert strategy.generation == 2


def test_settings_are_an_experiment_file_s_evolution_table():
    keys = dict(algorithm="cmaes", population=10, initial_sigma=1.5, cmaes_variant="separable")
    toml = "\n".join(
        ['algorithm = "cmaes"', "population = 10", "initial_sigma = 1.5", 'cmaes_variant = "separable"']
    )
    states = [
        hevo.Strategy(n_genes=4, seed=3, **keys).state(),
        hevo.Strategy(n_genes=4, seed=3, settings=keys).state(),
        hevo.Strategy("cmaes", n_genes=4, seed=3, settings={"population": 10, "initial_sigma": 1.5},
                      cmaes_variant="separable").state(),
    ]
    asks = [hevo.Strategy.from_state(s).ask() for s in states]
    for settings in (toml, "[evolution]\n" + toml):
        asks.append(hevo.Strategy(n_genes=4, seed=3, settings=settings).ask())
    assert asks[0].shape == (10, 4)
    for other in asks[1:]:
        assert np.array_equal(asks[0], other)
    # The paper's GA with its defaults when nothing is said.
    default = hevo.Strategy(n_genes=4)
    assert default.algorithm == "ga" and default.ask().shape == (100, 4)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(algorithm="annealing"), r"(?s)evolution\.algorithm.*unknown variant `annealing`"),
        (dict(populaton=10), r"populaton"),
        (dict(restarts=2), r"at `evolution\.restarts`: is a setting of algorithm \"cmaes\"; the algorithm here is \"ga\""),
        (dict(population=30, elites=4), r"at `evolution\.population`: population \(30\) must be a multiple of elites \(4\)"),
        (dict(algorithm="cmaes", initial_sigma=-1.0), r"evolution\.initial_sigma"),
        (dict(settings="population = ["), r"unclosed array"),
    ],
)
def test_bad_settings_are_refused_with_the_experiment_file_s_messages(kwargs, message):
    with pytest.raises(hevo.ConfigError, match=message) as error:
        hevo.Strategy(n_genes=3, **kwargs)
    assert str(error.value).startswith("hevo.Strategy settings")


def test_bad_arguments_and_states_are_refused():
    with pytest.raises(ValueError, match="n_genes must be 1 to"):
        hevo.Strategy(n_genes=0)
    with pytest.raises(TypeError, match="settings must be a dict or the TOML text"):
        hevo.Strategy(n_genes=3, settings=3)
    with pytest.raises(hevo.ConfigError, match="not a saved hevo.Strategy"):
        hevo.Strategy.from_state(b"{}")
    saved = json.loads(hevo.Strategy("ga", n_genes=3, population=4, elites=2).state())
    saved["settings"] = {"algorithm": "cmaes", "population": 4}
    with pytest.raises(hevo.ConfigError, match="the state is of algorithm 'ga', the settings are for 'cmaes'"):
        hevo.Strategy.from_state(json.dumps(saved))
    saved["settings"] = {"algorithm": "ga", "population": 4, "elites": 2}
    saved["n_genes"] = 4
    with pytest.raises(hevo.ConfigError, match="the saved state does not fit"):
        hevo.Strategy.from_state(json.dumps(saved))


def test_every_algorithm_the_settings_reader_knows_works_here():
    # The reader's own list, from its message for an unknown one: an algorithm added to the
    # experiment file's schema is tested here without a change to this test.
    with pytest.raises(hevo.ConfigError) as error:
        hevo.Strategy("no such algorithm", n_genes=2)
    known = re.findall(r"`(\w+)`", str(error.value).split("expected one of", 1)[1])
    assert {"ga", "cmaes", "novelty", "map_elites"} <= set(known), known
    # What an algorithm cannot run without: MAP-Elites' grid over the descriptor.
    required = {"map_elites": {"map_elites_ranges": [[-1.0, 1.0], [-1.0, 1.0]]}}
    for algorithm in known:
        strategy = hevo.Strategy(algorithm, n_genes=3, seed=1, **required.get(algorithm, {}))
        assert strategy.algorithm == algorithm
        # Two generations with the shipped tasks' descriptor width (final x and y).
        step_2d = lambda g: strategy.tell(sphere(g), descriptors=g[:, :2])  # noqa: E731
        step_2d(strategy.ask())
        step_2d(strategy.ask())
        resumed = hevo.Strategy.from_state(strategy.state())
        assert np.array_equal(resumed.ask(), strategy.ask()), algorithm
        assert resumed.generation == 2 and strategy.best is not None


def test_the_archive_of_a_map_elites_strategy_is_what_it_was_told():
    strategy = hevo.Strategy("map_elites", n_genes=3, seed=1, population=4,
                             map_elites_bins=[2, 2], map_elites_ranges=[[0, 1], [0, 1]])
    assert hevo.Strategy("ga", n_genes=3).archive is None
    genomes = strategy.ask()
    # Two genomes in cell (0, 0) (the fitter stays), one in (1, 1), one in (0, 1).
    strategy.tell([1.0, 2.0, 0.5, -1.0],
                  [[0.1, 0.1], [0.2, 0.2], [0.9, 0.9], [0.1, 0.9]])
    archive = strategy.archive
    assert (archive["cells"], archive["filled"]) == (4, 3)
    assert archive["coverage"] == 0.75 and archive["qd_score"] == 1.5 and archive["best"] == 2.0
    assert archive["cell"].tolist() == [0, 1, 3]
    assert archive["fitness"].tolist() == [2.0, -1.0, 0.5]
    assert archive["descriptor"].tolist() == [[0.2, 0.2], [0.1, 0.9], [0.9, 0.9]]
    assert np.array_equal(archive["genes"], genomes[[1, 3, 2]])


def test_map_elites_needs_its_ranges_and_fills_in_its_bins():
    with pytest.raises(hevo.ConfigError, match="evolution.map_elites_ranges`: required"):
        hevo.Strategy("map_elites", n_genes=3)
    three = hevo.Strategy("map_elites", n_genes=3, map_elites_ranges=[[0, 1]] * 3)
    assert three.archive["cells"] == 10**3
    with pytest.raises(hevo.ConfigError, match="map_elites_bins"):
        hevo.Strategy("map_elites", n_genes=3, map_elites_bins=[4],
                      map_elites_ranges=[[0, 1], [0, 1]])
