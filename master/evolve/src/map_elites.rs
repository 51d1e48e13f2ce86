//! MAP-Elites (Mouret & Clune 2015) as a [`Strategy`]: a grid archive over the behaviour
//! descriptor keeps, in each cell, the fittest genome told whose behaviour fell there, and every
//! generation asks for `population` genomes (batched, as pyribs' emitters do), each a variation
//! of parents drawn uniformly from the filled cells.
//!
//! - **Cells.** Descriptor value `d` of range `[lo, hi)` in `bins[d]` equal bins: bin
//!   `floor((v - lo) / (hi - lo) * bins[d])`; a value outside the range is clamped into the
//!   edge bin (so every genome told has a cell). Cells are numbered row-major, the first
//!   descriptor value slowest: cell = `(bin_0 * bins_1 + bin_1) * bins_2 + ...`.
//! - **Insertion.** A genome enters an empty cell, or replaces the elite of a filled one when
//!   strictly fitter (a tie keeps the elite). Within a generation genomes are inserted in the
//!   order asked, so the outcome is fully determined by the results.
//! - **Variation.** The first `initial` genomes asked for (and any asked while the archive is
//!   empty) are random, genes from N(0, initial_sigma^2); after that each is a parent x with a
//!   Gaussian offset N(0, sigma^2) on every gene (`gaussian`), or Vassiliades & Mouret's (2018)
//!   iso+line `x + sigma N(0, I) + line_sigma N(0, 1) (y - x)` with a second parent y
//!   (`iso_line`). Every gene is then clamped to the gene range, as the GA and CMA-ES do.
//! - **Draws.** Generation g's genomes come from the run's stream for (MAP-Elites, g) alone, so
//!   the state (the archive and the genomes asked for next) determines the rest of the run.
//! - **Result.** The best elite: the fittest in the archive (ties to the lower cell). Its
//!   fitness was measured on the samples of the generation it was told in.
//!
//! QD-score is the plain sum of the elites' fitness (pyribs' `qd_score` with offset 0) and
//! coverage the share of cells filled; both are kept per generation in the state, so the
//! run's log of them continues exactly after a resume.

use crate::seeds::{RunStream, stream};
use crate::{
    Evaluation, Strategy, StrategyError, StrategyState, check_gene_range, check_results,
    check_spreads,
};
use rand::RngExt;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// MAP-Elites' name in experiment files and saved states.
pub const ALGORITHM: &str = "map_elites";

/// The most bins along one descriptor value.
pub const MAX_BINS: u32 = 1_000;

/// The most cells a grid may have (the product of its bins).
pub const MAX_CELLS: u64 = 1_000_000;

/// The most genes a full archive may hold (cells x genes per genome): 512 MiB of `f32`, checked
/// before a run starts so a large grid of large genomes is refused rather than run out of
/// memory late in a run.
pub const MAX_ARCHIVE_GENES: u64 = 1 << 27;

/// How a new genome is made from the archive's elites.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Variation {
    /// A parent with a Gaussian offset N(0, sigma^2) on every gene.
    #[default]
    Gaussian,
    /// Vassiliades & Mouret's iso+line: `x + sigma N(0, I) + line_sigma N(0, 1) (y - x)`.
    IsoLine,
}

/// MAP-Elites' settings.
#[derive(Debug, Clone, PartialEq)]
pub struct MapElitesSettings {
    /// Genomes asked for per generation (the batch).
    pub population: u32,
    /// Standard deviation of the random genomes' genes (mean 0).
    pub initial_sigma: f64,
    /// Genes are clamped to this range.
    pub gene_range: [f64; 2],
    /// Bins along each descriptor value; as many as the descriptor has values.
    pub bins: Vec<u32>,
    /// Each descriptor value's range `[lo, hi]`, cut into its bins; values outside go to the
    /// edge bins.
    pub ranges: Vec<[f64; 2]>,
    /// How new genomes are made from elites.
    pub variation: Variation,
    /// The Gaussian offset's standard deviation (iso+line's sigma_iso).
    pub sigma: f64,
    /// Iso+line's sigma_line: the spread along the line between the two parents.
    pub line_sigma: f64,
    /// Random genomes asked for before variation starts.
    pub initial: u32,
}

impl Default for MapElitesSettings {
    /// A population of 100 (the paper's GA's), the GA's initial genes and gene range, Gaussian
    /// variation of sigma 0.5, iso+line's sigma_line 0.2 (Vassiliades & Mouret's value), one
    /// batch of random genomes; a 10 x 10 grid over [0, 1]^2, which a run replaces by its
    /// descriptor's.
    fn default() -> MapElitesSettings {
        MapElitesSettings {
            population: 100,
            initial_sigma: 2.0,
            gene_range: [-10.0, 10.0],
            bins: vec![10, 10],
            ranges: vec![[0.0, 1.0]; 2],
            variation: Variation::Gaussian,
            sigma: 0.5,
            line_sigma: 0.2,
            initial: 100,
        }
    }
}

impl MapElitesSettings {
    /// Checks the settings' domain, naming the key at fault.
    pub fn check(&self) -> Result<(), StrategyError> {
        let fail =
            |key: &'static str, message: String| Err(StrategyError::Settings { key, message });
        if self.population == 0 {
            return fail("population", "must be at least 1".into());
        }
        if self.bins.is_empty() {
            return fail(
                "map_elites_bins",
                "must have one entry per descriptor value".into(),
            );
        }
        if let Some(bad) = self.bins.iter().find(|&&b| !(1..=MAX_BINS).contains(&b)) {
            return fail(
                "map_elites_bins",
                format!("each must be between 1 and {MAX_BINS}, got {bad}"),
            );
        }
        if self.n_cells().is_none_or(|cells| cells > MAX_CELLS) {
            return fail(
                "map_elites_bins",
                format!(
                    "a grid of {} cells; at most {MAX_CELLS} are accepted",
                    self.bins
                        .iter()
                        .map(u32::to_string)
                        .collect::<Vec<_>>()
                        .join(" x ")
                ),
            );
        }
        if self.ranges.len() != self.bins.len() {
            return fail(
                "map_elites_ranges",
                format!(
                    "{} ranges for {} descriptor values (map_elites_bins has {})",
                    self.ranges.len(),
                    self.bins.len(),
                    self.bins.len()
                ),
            );
        }
        if let Some([lo, hi]) = self
            .ranges
            .iter()
            .find(|[lo, hi]| !(lo.is_finite() && hi.is_finite() && lo < hi))
        {
            return fail(
                "map_elites_ranges",
                format!("each must be [lo, hi], finite, with lo < hi, got [{lo}, {hi}]"),
            );
        }
        check_spreads(&[
            ("initial_sigma", self.initial_sigma),
            ("map_elites_sigma", self.sigma),
            ("map_elites_line_sigma", self.line_sigma),
        ])?;
        check_gene_range(self.gene_range)
    }

    /// The grid's cells, when their count fits in a `u64`.
    pub fn n_cells(&self) -> Option<u64> {
        self.bins
            .iter()
            .try_fold(1u64, |cells, &b| cells.checked_mul(u64::from(b)))
    }

    /// Checks that a full archive of genomes of `n_genes` genes fits [`MAX_ARCHIVE_GENES`].
    pub fn check_archive_size(&self, n_genes: usize) -> Result<(), StrategyError> {
        let cells = self.n_cells().unwrap_or(u64::MAX);
        if cells.saturating_mul(n_genes as u64) > MAX_ARCHIVE_GENES {
            return Err(StrategyError::Settings {
                key: "map_elites_bins",
                message: format!(
                    "a full archive of {cells} cells of genomes of {n_genes} genes holds more than {MAX_ARCHIVE_GENES} genes: use fewer bins"
                ),
            });
        }
        Ok(())
    }

    /// The cell a descriptor falls in (values outside their range in the edge bin), and its
    /// bin along each value.
    pub fn cell_of(&self, descriptor: &[f64]) -> (u64, Vec<u32>) {
        let bins: Vec<u32> = descriptor
            .iter()
            .zip(&self.bins)
            .zip(&self.ranges)
            .map(|((&value, &n_bins), &[lo, hi])| {
                let share = (value - lo) / (hi - lo);
                // Saturating: a share far outside [0, 1] (or NaN, refused earlier) lands at an edge.
                ((share * f64::from(n_bins)).floor() as i64).clamp(0, i64::from(n_bins) - 1) as u32
            })
            .collect();
        let cell = bins
            .iter()
            .zip(&self.bins)
            .fold(0u64, |cell, (&bin, &n_bins)| {
                cell * u64::from(n_bins) + u64::from(bin)
            });
        (cell, bins)
    }
}

/// One filled cell of the archive.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Elite {
    /// The cell's index (row-major, the first descriptor value slowest).
    pub cell: u64,
    /// The elite's fitness, as told.
    pub fitness: f64,
    /// Its behaviour descriptor, as told (before clamping into the grid).
    pub descriptor: Vec<f64>,
    /// Its genes.
    pub genes: Vec<f32>,
}

/// The archive's measures after one generation was told.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QdPoint {
    /// Cells filled.
    pub filled: u64,
    /// The sum of the elites' fitness.
    pub qd_score: f64,
    /// The best elite's fitness.
    pub best: f64,
}

/// MAP-Elites' whole state.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MapElitesState {
    /// The run's seed: every draw of the run derives from it.
    pub run_seed: u64,
    /// Generations told so far.
    pub generation: u32,
    /// The genomes to evaluate next.
    pub batch: Vec<Vec<f32>>,
    /// The archive's elites, by cell.
    pub elites: Vec<Elite>,
    /// The archive's measures after each generation told.
    pub history: Vec<QdPoint>,
}

/// The grid archive: its shape, its elites by cell and its measures per generation.
#[derive(Debug, Clone)]
pub struct GridArchive {
    settings: MapElitesSettings,
    elites: BTreeMap<u64, Elite>,
    history: Vec<QdPoint>,
}

impl GridArchive {
    /// Bins along each descriptor value.
    pub fn bins(&self) -> &[u32] {
        &self.settings.bins
    }

    /// Each descriptor value's range.
    pub fn ranges(&self) -> &[[f64; 2]] {
        &self.settings.ranges
    }

    /// The grid's cells.
    pub fn n_cells(&self) -> u64 {
        self.settings.n_cells().expect("checked when started")
    }

    /// The elites, by cell.
    pub fn elites(&self) -> impl Iterator<Item = &Elite> {
        self.elites.values()
    }

    /// A cell's bin along each descriptor value.
    pub fn bins_of(&self, cell: u64) -> Vec<u32> {
        let mut rest = cell;
        let mut bins: Vec<u32> = self
            .settings
            .bins
            .iter()
            .rev()
            .map(|&n_bins| {
                let bin = (rest % u64::from(n_bins)) as u32;
                rest /= u64::from(n_bins);
                bin
            })
            .collect();
        bins.reverse();
        bins
    }

    /// The archive's measures after each generation told.
    pub fn history(&self) -> &[QdPoint] {
        &self.history
    }

    /// The fittest elite (ties to the lower cell).
    pub fn best(&self) -> Option<&Elite> {
        // Cells ascending, so keeping the first of equals keeps the lower cell.
        self.elites
            .values()
            .fold(None, |best: Option<&Elite>, e| match best {
                Some(b) if b.fitness >= e.fitness => Some(b),
                _ => Some(e),
            })
    }

    /// Files a told genome: into an empty cell, or over a less fit elite. Whether it entered.
    fn insert(&mut self, genes: &[f32], fitness: f64, descriptor: &[f64]) -> bool {
        let (cell, _) = self.settings.cell_of(descriptor);
        if self.elites.get(&cell).is_some_and(|e| e.fitness >= fitness) {
            return false;
        }
        self.elites.insert(
            cell,
            Elite {
                cell,
                fitness,
                descriptor: descriptor.to_vec(),
                genes: genes.to_vec(),
            },
        );
        true
    }

    /// The archive's measures now.
    fn measure(&self) -> QdPoint {
        QdPoint {
            filled: self.elites.len() as u64,
            qd_score: self.elites.values().map(|e| e.fitness).sum(),
            best: self.best().map_or(f64::NEG_INFINITY, |e| e.fitness),
        }
    }
}

/// MAP-Elites as a [`Strategy`].
#[derive(Debug, Clone)]
pub struct MapElites {
    archive: GridArchive,
    run_seed: u64,
    generation: u32,
    n_genes: usize,
    batch: Vec<Vec<f32>>,
}

impl MapElites {
    /// A new run: an empty archive and a first batch of random genomes of `n_genes` genes.
    pub fn start(
        settings: MapElitesSettings,
        n_genes: usize,
        run_seed: u64,
    ) -> Result<MapElites, StrategyError> {
        settings.check()?;
        settings.check_archive_size(n_genes)?;
        let mut map_elites = MapElites {
            archive: GridArchive {
                settings,
                elites: BTreeMap::new(),
                history: Vec::new(),
            },
            run_seed,
            generation: 0,
            n_genes,
            batch: Vec::new(),
        };
        map_elites.batch = map_elites.next_batch();
        Ok(map_elites)
    }

    /// A run continued from its saved state, which must fit the settings and `n_genes`.
    pub fn resume(
        settings: MapElitesSettings,
        n_genes: usize,
        state: MapElitesState,
    ) -> Result<MapElites, StrategyError> {
        settings.check()?;
        settings.check_archive_size(n_genes)?;
        let MapElitesState {
            run_seed,
            generation,
            batch,
            elites,
            history,
        } = state;
        let refuse = |message: String| Err(StrategyError::State(message));
        if batch.len() != settings.population as usize {
            return refuse(format!(
                "a batch of {} genomes, the settings ask for {}",
                batch.len(),
                settings.population
            ));
        }
        if history.len() != generation as usize {
            return refuse(format!(
                "{} generations' measures for {generation} generations",
                history.len()
            ));
        }
        let genomes = batch.iter().chain(elites.iter().map(|e| &e.genes));
        for genome in genomes {
            if genome.len() != n_genes || genome.iter().any(|g| !g.is_finite()) {
                return refuse(format!(
                    "a genome of {} genes (finite: {}), expected {n_genes} finite genes",
                    genome.len(),
                    genome.iter().all(|g| g.is_finite())
                ));
            }
        }
        let mut archive = GridArchive {
            settings,
            elites: BTreeMap::new(),
            history,
        };
        for elite in elites {
            let fits = elite.descriptor.len() == archive.settings.bins.len()
                && elite.descriptor.iter().all(|v| v.is_finite())
                && elite.fitness.is_finite()
                && archive.settings.cell_of(&elite.descriptor).0 == elite.cell;
            if !fits || archive.elites.contains_key(&elite.cell) {
                return refuse(format!(
                    "the elite of cell {} does not belong there in this grid (bins {:?}, ranges {:?})",
                    elite.cell, archive.settings.bins, archive.settings.ranges
                ));
            }
            archive.elites.insert(elite.cell, elite);
        }
        Ok(MapElites {
            archive,
            run_seed,
            generation,
            n_genes,
            batch,
        })
    }

    /// The archive.
    pub fn archive(&self) -> &GridArchive {
        &self.archive
    }

    /// The genomes of the current generation: random ones while the initial genomes are not
    /// all asked for (or the archive is empty), then variations of uniformly drawn elites.
    fn next_batch(&self) -> Vec<Vec<f32>> {
        let settings = &self.archive.settings;
        let mut rng = stream(
            self.run_seed,
            RunStream::MapElites,
            &[u64::from(self.generation)],
        );
        let parents: Vec<&Elite> = self.archive.elites.values().collect();
        let asked_before = u64::from(self.generation) * u64::from(settings.population);
        let [low, high] = settings.gene_range;
        let clamp = |gene: f64| gene.clamp(low, high) as f32;
        (0..u64::from(settings.population))
            .map(|genome_idx| {
                if parents.is_empty() || asked_before + genome_idx < u64::from(settings.initial) {
                    return (0..self.n_genes)
                        .map(|_| clamp(settings.initial_sigma * standard_normal(&mut rng)))
                        .collect();
                }
                let x = &parents[rng.random_range(0..parents.len())].genes;
                match settings.variation {
                    Variation::Gaussian => x
                        .iter()
                        .map(|&gene| {
                            clamp(f64::from(gene) + settings.sigma * standard_normal(&mut rng))
                        })
                        .collect(),
                    Variation::IsoLine => {
                        let y = &parents[rng.random_range(0..parents.len())].genes;
                        let along = settings.line_sigma * standard_normal(&mut rng);
                        x.iter()
                            .zip(y)
                            .map(|(&xi, &yi)| {
                                let (xi, yi) = (f64::from(xi), f64::from(yi));
                                clamp(
                                    xi + settings.sigma * standard_normal(&mut rng)
                                        + along * (yi - xi),
                                )
                            })
                            .collect()
                    }
                }
            })
            .collect()
    }
}

/// One draw of N(0, 1).
fn standard_normal<R: rand::Rng + ?Sized>(rng: &mut R) -> f64 {
    StandardNormal.sample(rng)
}

impl Strategy for MapElites {
    fn algorithm(&self) -> &'static str {
        ALGORITHM
    }

    fn generation(&self) -> u32 {
        self.generation
    }

    fn ask(&self) -> &[Vec<f32>] {
        &self.batch
    }

    fn tell(&mut self, results: &[Evaluation]) -> Result<(), StrategyError> {
        check_results(self.batch.len(), results)?;
        let dimensions = self.archive.settings.bins.len();
        if let Some(genome_idx) = results.iter().position(|r| {
            r.descriptor.len() != dimensions || r.descriptor.iter().any(|v| !v.is_finite())
        }) {
            return Err(StrategyError::Tell(format!(
                "genome {genome_idx}'s descriptor is {:?}, expected {dimensions} finite values (one per map_elites_bins entry)",
                results[genome_idx].descriptor
            )));
        }
        for (genes, result) in self.batch.iter().zip(results) {
            self.archive
                .insert(genes, result.fitness, &result.descriptor);
        }
        let point = self.archive.measure();
        self.archive.history.push(point);
        self.generation += 1;
        self.batch = self.next_batch();
        Ok(())
    }

    fn best(&self) -> Option<&[f32]> {
        self.archive.best().map(|e| e.genes.as_slice())
    }

    fn state(&self) -> StrategyState {
        StrategyState::MapElites(MapElitesState {
            run_seed: self.run_seed,
            generation: self.generation,
            batch: self.batch.clone(),
            elites: self.archive.elites.values().cloned().collect(),
            history: self.archive.history.clone(),
        })
    }

    fn grid(&self) -> Option<&GridArchive> {
        Some(&self.archive)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings() -> MapElitesSettings {
        MapElitesSettings {
            population: 8,
            bins: vec![4, 5],
            ranges: vec![[0.0, 4.0], [-1.0, 1.0]],
            initial: 8,
            ..MapElitesSettings::default()
        }
    }

    /// A toy task: behaviour the first two genes, fitness minus the distance of all genes to 1.
    fn evaluate(genes: &[f32]) -> Evaluation {
        let fitness = -genes
            .iter()
            .map(|&g| (f64::from(g) - 1.0).abs())
            .sum::<f64>();
        Evaluation::with_descriptor(fitness, vec![f64::from(genes[0]), f64::from(genes[1])])
    }

    fn run(strategy: &mut MapElites, generations: u32) {
        for _ in 0..generations {
            let results: Vec<Evaluation> = strategy.ask().iter().map(|g| evaluate(g)).collect();
            strategy.tell(&results).unwrap();
        }
    }

    #[test]
    fn cells_are_row_major_with_values_outside_in_the_edge_bins() {
        let s = settings();
        assert_eq!(s.n_cells(), Some(20));
        // Bin width 1 along the first value, 0.4 along the second.
        assert_eq!(s.cell_of(&[0.0, -1.0]), (0, vec![0, 0]));
        assert_eq!(s.cell_of(&[0.999, -0.61]), (0, vec![0, 0]));
        assert_eq!(s.cell_of(&[1.0, -0.6]), (6, vec![1, 1]));
        assert_eq!(s.cell_of(&[3.5, 0.99]), (19, vec![3, 4]));
        // The upper edge belongs to the last bin, as does everything beyond; below, the first.
        assert_eq!(s.cell_of(&[4.0, 1.0]), (19, vec![3, 4]));
        assert_eq!(s.cell_of(&[1e300, -1e300]), (15, vec![3, 0]));
        assert_eq!(s.cell_of(&[-7.0, 0.1]), (2, vec![0, 2]));
        let archive = MapElites::start(s, 2, 1).unwrap().archive;
        for cell in 0..20 {
            let bins = archive.bins_of(cell);
            let centre: Vec<f64> = bins
                .iter()
                .zip(archive.ranges())
                .zip(archive.bins())
                .map(|((&b, &[lo, hi]), &n)| lo + (f64::from(b) + 0.5) * (hi - lo) / f64::from(n))
                .collect();
            assert_eq!(archive.settings.cell_of(&centre), (cell, bins));
        }
    }

    #[test]
    fn an_elite_is_replaced_only_by_a_strictly_fitter_genome() {
        let mut archive = MapElites::start(settings(), 2, 1).unwrap().archive;
        assert!(archive.insert(&[0.0, 0.0], 1.0, &[0.5, 0.0]));
        // Same cell: worse and equal are refused, better replaces.
        assert!(!archive.insert(&[1.0, 1.0], 0.5, &[0.6, 0.1]));
        assert!(!archive.insert(&[2.0, 2.0], 1.0, &[0.7, 0.1]));
        assert_eq!(archive.elites().next().unwrap().genes, [0.0, 0.0]);
        assert!(archive.insert(&[3.0, 3.0], 1.5, &[0.1, 0.1]));
        // Another cell, worse than the elite elsewhere: it enters its own cell.
        assert!(archive.insert(&[4.0, 4.0], -2.0, &[3.5, 0.9]));
        let elites: Vec<(u64, f64, &[f32])> = archive
            .elites()
            .map(|e| (e.cell, e.fitness, e.genes.as_slice()))
            .collect();
        assert_eq!(elites, [(2, 1.5, &[3.0, 3.0][..]), (19, -2.0, &[4.0, 4.0])]);
        let point = archive.measure();
        assert_eq!((point.filled, point.qd_score, point.best), (2, -0.5, 1.5));
        assert_eq!(archive.best().unwrap().cell, 2);
    }

    #[test]
    fn iso_line_and_gaussian_genomes_stay_in_the_gene_range() {
        for variation in [Variation::Gaussian, Variation::IsoLine] {
            let wide = MapElitesSettings {
                variation,
                gene_range: [-1.5, 2.0],
                initial_sigma: 5.0,
                sigma: 3.0,
                line_sigma: 4.0,
                ..settings()
            };
            let mut strategy = MapElites::start(wide, 6, 4).unwrap();
            for _ in 0..20 {
                for genome in strategy.ask() {
                    assert!(
                        genome.iter().all(|g| (-1.5..=2.0).contains(g)),
                        "{genome:?}"
                    );
                }
                run(&mut strategy, 1);
            }
            // The edges are reached: the range does bind.
            let genes: Vec<f32> = strategy.ask().iter().flatten().copied().collect();
            assert!(genes.contains(&-1.5) && genes.contains(&2.0));
        }
    }

    #[test]
    fn iso_line_moves_along_the_line_between_its_parents() {
        // No isotropic part: every child lies on the line through two elites.
        let line_only = MapElitesSettings {
            variation: Variation::IsoLine,
            sigma: 0.0,
            line_sigma: 0.5,
            ..settings()
        };
        let mut strategy = MapElites::start(line_only, 3, 2).unwrap();
        run(&mut strategy, 1);
        let elites: Vec<Vec<f64>> = strategy
            .archive
            .elites()
            .map(|e| e.genes.iter().map(|&g| f64::from(g)).collect())
            .collect();
        for child in strategy.ask() {
            let child: Vec<f64> = child.iter().map(|&g| f64::from(g)).collect();
            let on_a_line = elites.iter().any(|x| {
                elites.iter().any(|y| {
                    // child - x parallel to y - x (or child == x).
                    let t = (0..3)
                        .map(|i| (child[i] - x[i]) / (y[i] - x[i]))
                        .collect::<Vec<_>>();
                    (0..3).all(|i| (child[i] - x[i]).abs() < 1e-5)
                        || t.iter().all(|ti| (ti - t[0]).abs() < 1e-3)
                })
            });
            assert!(on_a_line, "{child:?} is on no line between elites");
        }
    }

    #[test]
    fn the_first_genomes_are_random_then_variations_and_the_run_is_its_seed_s() {
        let s = MapElitesSettings {
            initial: 12,
            sigma: 0.1,
            ..settings()
        };
        let mut strategy = MapElites::start(s.clone(), 4, 9).unwrap();
        let first = strategy.ask().to_vec();
        run(&mut strategy, 1);
        // Generation 1: genomes 8..12 are the initial's last four, 12..16 variations of elites,
        // each at most a few sigma from an elite in every gene.
        let elites: Vec<&Elite> = strategy.archive.elites().collect();
        let near_an_elite = |genome: &[f32]| {
            elites.iter().any(|e| {
                e.genes
                    .iter()
                    .zip(genome)
                    .all(|(a, b)| (a - b).abs() < 6.0 * s.sigma as f32)
            })
        };
        let batch = strategy.ask();
        assert!(batch[4..].iter().all(|g| near_an_elite(g)));
        assert!(batch[..4].iter().any(|g| !near_an_elite(g)));
        // The same seed, the same run; another seed, another.
        let mut again = MapElites::start(s.clone(), 4, 9).unwrap();
        assert_eq!(again.ask(), first);
        run(&mut again, 1);
        assert_eq!(again.ask(), strategy.ask());
        assert_ne!(MapElites::start(s, 4, 10).unwrap().ask(), first);
    }

    #[test]
    fn it_fills_more_cells_and_scores_higher_as_it_goes() {
        let mut strategy = MapElites::start(settings(), 4, 3).unwrap();
        run(&mut strategy, 30);
        let history = strategy.archive.history();
        assert_eq!(history.len(), 30);
        let (first, last) = (history[0], history[29]);
        assert!(last.filled > first.filled, "{history:?}");
        assert!(last.best >= first.best);
        // Each elite only ever improves, so with a fixed set of cells the score grows too.
        for pair in history.windows(2) {
            assert!(pair[1].filled >= pair[0].filled);
            assert!(pair[1].best >= pair[0].best);
        }
        assert_eq!(
            strategy.best(),
            Some(strategy.archive.best().unwrap().genes.as_slice())
        );
    }

    #[test]
    fn misshapen_descriptors_are_refused_and_change_nothing() {
        let mut strategy = MapElites::start(settings(), 4, 1).unwrap();
        let before = strategy.state();
        let n = strategy.ask().len();
        let error = strategy.tell(&vec![Evaluation::new(1.0); n]).unwrap_err();
        assert!(
            error.to_string().starts_with("genome 0's descriptor is []"),
            "{error}"
        );
        let mut results: Vec<Evaluation> = strategy.ask().iter().map(|g| evaluate(g)).collect();
        results[3].descriptor[1] = f64::INFINITY;
        let error = strategy.tell(&results).unwrap_err();
        assert!(error.to_string().starts_with("genome 3's"), "{error}");
        assert_eq!(strategy.state(), before);
    }

    #[test]
    fn a_state_that_does_not_fit_the_grid_is_refused() {
        let mut strategy = MapElites::start(settings(), 4, 1).unwrap();
        run(&mut strategy, 3);
        let StrategyState::MapElites(state) = strategy.state() else {
            unreachable!()
        };
        let finer = MapElitesSettings {
            bins: vec![8, 5],
            ..settings()
        };
        let error = MapElites::resume(finer, 4, state.clone()).unwrap_err();
        assert!(
            error.to_string().contains("does not belong there"),
            "{error}"
        );
        let error = MapElites::resume(settings(), 5, state.clone()).unwrap_err();
        assert!(
            error.to_string().contains("expected 5 finite genes"),
            "{error}"
        );
        let mut short = state.clone();
        short.history.pop();
        let error = MapElites::resume(settings(), 4, short).unwrap_err();
        assert!(
            error.to_string().contains("2 generations' measures"),
            "{error}"
        );
        assert!(MapElites::resume(settings(), 4, state).is_ok());
    }

    #[test]
    fn bad_settings_name_their_key() {
        let key = |settings: MapElitesSettings| match settings.check() {
            Err(StrategyError::Settings { key, .. }) => key,
            other => panic!("{other:?}"),
        };
        let with = |edit: fn(&mut MapElitesSettings)| {
            let mut s = settings();
            edit(&mut s);
            key(s)
        };
        assert_eq!(with(|s| s.bins = vec![]), "map_elites_bins");
        assert_eq!(with(|s| s.bins = vec![0, 5]), "map_elites_bins");
        assert_eq!(with(|s| s.bins = vec![1001, 5]), "map_elites_bins");
        assert_eq!(with(|s| s.bins = vec![1000, 1000, 2]), "map_elites_bins");
        assert_eq!(
            with(|s| s.ranges.pop().map(drop).unwrap()),
            "map_elites_ranges"
        );
        assert_eq!(with(|s| s.ranges[1] = [1.0, 1.0]), "map_elites_ranges");
        assert_eq!(with(|s| s.ranges[0] = [0.0, f64::NAN]), "map_elites_ranges");
        assert_eq!(with(|s| s.sigma = -1.0), "map_elites_sigma");
        assert_eq!(
            with(|s| s.line_sigma = f64::INFINITY),
            "map_elites_line_sigma"
        );
        assert_eq!(with(|s| s.population = 0), "population");
        // A grid that is fine alone but too large for its genomes' archive.
        let big = MapElitesSettings {
            bins: vec![1000, 1000],
            ranges: vec![[0.0, 1.0]; 2],
            ..settings()
        };
        assert!(big.check().is_ok());
        match MapElites::start(big, 200, 1).unwrap_err() {
            StrategyError::Settings { key, message } => {
                assert_eq!(key, "map_elites_bins");
                assert!(message.contains("1000000 cells"), "{message}");
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn the_draws_are_pinned() {
        // Every MAP-Elites run is resumed from its checkpoint with these draws: a change to the
        // stream, the variation or the insertion changes this hash.
        let mut hash = 0xcbf2_9ce4_8422_2325u64;
        for variation in [Variation::Gaussian, Variation::IsoLine] {
            let s = MapElitesSettings {
                variation,
                ..settings()
            };
            let mut strategy = MapElites::start(s, 3, 11).unwrap();
            run(&mut strategy, 5);
            for gene in strategy.ask().iter().flatten() {
                hash = (hash ^ u64::from(gene.to_bits())).wrapping_mul(0x0100_0000_01b3);
            }
        }
        assert_eq!(hash, 11591440280842995414);
    }
}
