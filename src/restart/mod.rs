//! Restart files: where a run stands, written so that a later run continues it bit for bit.
//!
//! A [`Snapshot`] holds everything of a run that evolves ([`crate::state::State`]: u, v, a,
//! forces, current positions, bond damage, every staged history field, contact's last
//! search) and where the run is in its deck (solver list, step, time, the quasi-static load
//! schedule with its cuts, the stability monitor, the output frame counters), plus two
//! hashes of the deck: one of the body and its physics, one of the solver lists.
//!
//! Points and bonds are stored in the user's original order (bonds by the original ids of
//! their two ends), never in run order, so that a file does not depend on the renumbering.
//! With the `hdf5` feature a snapshot is one HDF5 file, `restart-NNNNNN/restart.h5` in the
//! output folder ([`directory`]); without it every deck that asks for restart is refused by
//! `peridyn check` and `peridyn run` alike.
//!
//! Restart directories are numbered as Peridigm numbers them (`restart-000001`, …); a run
//! resumes from the highest number. A directory is written under a temporary name and renamed
//! when complete, so a run killed while writing leaves the previous one intact; only the two
//! newest are kept.

mod capture;
#[cfg(feature = "hdf5")]
mod hdf5_file;

pub use capture::{apply, capture};

use crate::model::Model;
use std::path::{Path, PathBuf};

/// Version of the snapshot layout; a file of another version is refused.
pub const FORMAT_VERSION: u64 = 1;

/// Name of the snapshot inside a restart directory.
pub const FILE_NAME: &str = "restart.h5";

/// Restart directories kept: the newest and the one before it.
const KEEP: usize = 2;

/// Where a run stands in its deck.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Position {
    /// Index of the solver list in the deck (equal to the number of lists once all are done).
    pub solver: usize,
    /// Steps (explicit) or accepted load steps (quasi-static) done in that list; 0 when the
    /// list has not started.
    pub step: u64,
}

/// The load-step schedule of a quasi-static list: its times with the cuts made so far, the
/// next step to solve and the counts that decide the next cut and the predictor.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LoadSchedule {
    /// Load-step end times, the cuts included (s).
    pub times: Vec<f64>,
    /// The next step to solve goes from `times[next − 1]` to `times[next]`.
    pub next: usize,
    /// Cuts made in the list so far.
    pub total_cuts: u64,
    /// Steps accepted in the list so far.
    pub accepted: usize,
}

/// Where one results file stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct OutputPosition {
    /// Output calls counted (Peridigm's schedule counts calls).
    pub calls: i64,
    /// Frames in the Exodus file.
    pub frames: u64,
    /// Rows in the CSV of global variables (0 without one).
    pub rows: u64,
}

/// A staged history field in original order.
#[derive(Debug, Clone, PartialEq)]
pub struct HistoryField {
    /// Declared name.
    pub name: String,
    /// True for a bond field, false for a point field.
    pub per_bond: bool,
    /// Numbers per point or bond.
    pub width: usize,
    /// The accepted values.
    pub values: Vec<f64>,
}

/// Contact's last search: the positions it was made at (its candidates follow from them).
#[derive(Debug, Clone, PartialEq)]
pub struct ContactSnapshot {
    /// Positions of the contact points at the last search, in original order of the points;
    /// `None` before the first search.
    pub searched_at: Option<Vec<[f64; 3]>>,
    /// Contact force density of every point at the last evaluation (force/length³).
    pub force_density: Vec<[f64; 3]>,
}

/// Everything a continuation needs, in the user's original order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Snapshot {
    /// Hash of the body and its physics ([`model_hash`]).
    pub model_hash: u64,
    /// Hash of the deck's solver lists ([`solvers_hash`]).
    pub solvers_hash: u64,
    /// Where the run stands.
    pub position: Position,
    /// Time t (s).
    pub time: f64,
    /// Displacement, velocity, acceleration, internal force density and current position.
    pub displacement: Vec<[f64; 3]>,
    /// Velocity (length/s).
    pub velocity: Vec<[f64; 3]>,
    /// Acceleration (length/s²).
    pub acceleration: Vec<[f64; 3]>,
    /// Internal force density (force/length³).
    pub force_density: Vec<[f64; 3]>,
    /// Current position Y (length).
    pub current_position: Vec<[f64; 3]>,
    /// Body force density, when the deck has a body force.
    pub external_force_density: Option<Vec<[f64; 3]>>,
    /// Bond damage per directed bond, when a block has a damage model.
    pub bond_damage: Option<Vec<f32>>,
    /// Staged history fields.
    pub history: Vec<HistoryField>,
    /// Δt the history's trial values advance over (s).
    pub history_step_duration: f64,
    /// Contact's state, when the run has contact.
    pub contact: Option<ContactSnapshot>,
    /// The load schedule of a quasi-static list stopped inside it.
    pub load_schedule: Option<LoadSchedule>,
    /// The stability monitor of an explicit list stopped inside it: initial energy and work
    /// supplied so far.
    pub monitor: Option<[f64; 2]>,
    /// Per deck `Output` list, in deck order.
    pub outputs: Vec<OutputPosition>,
    /// Rows of `<output>_solver.csv`.
    pub solver_rows: u64,
    /// Steps taken and bonds broken so far (the run's summary).
    pub steps: u64,
    /// Bonds broken so far.
    pub broken_bonds: u64,
}

/// Why a restart file cannot be written or read.
#[derive(Debug, thiserror::Error)]
pub enum RestartError {
    /// The file system refused.
    #[error("{path}: {action}: {source}")]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// What was being done.
        action: &'static str,
        /// The cause.
        source: std::io::Error,
    },
    /// The HDF5 library refused, or the file is not a peridyn restart file.
    #[error("{path}: {problem}")]
    File {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        problem: String,
    },
    /// This build has no HDF5.
    #[error("restart files need a build with the `hdf5` feature (`apt-get install libhdf5-dev`, then `cargo build --release --features hdf5`)")]
    NoHdf5,
}

/// Writes `snapshot` to `path` (an HDF5 file).
pub fn write(path: &Path, snapshot: &Snapshot) -> Result<(), RestartError> {
    #[cfg(feature = "hdf5")]
    {
        hdf5_file::write(path, snapshot)
    }
    #[cfg(not(feature = "hdf5"))]
    {
        let _ = (path, snapshot);
        Err(RestartError::NoHdf5)
    }
}

/// Reads the snapshot at `path`.
pub fn read(path: &Path) -> Result<Snapshot, RestartError> {
    #[cfg(feature = "hdf5")]
    {
        hdf5_file::read(path)
    }
    #[cfg(not(feature = "hdf5"))]
    {
        let _ = path;
        Err(RestartError::NoHdf5)
    }
}

/// The directory of restart number `number` in `dir`: `restart-000042`, as Peridigm names them.
pub fn directory(dir: &Path, number: u64) -> PathBuf {
    dir.join(format!("restart-{number:06}"))
}

/// The complete restart directories in `dir`, by number (an unreadable or missing `dir` has
/// none).
pub fn directories(dir: &Path) -> Vec<(u64, PathBuf)> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut found: Vec<(u64, PathBuf)> = entries
        .flatten()
        .filter_map(|entry| {
            let name = entry.file_name();
            let number = name.to_str()?.strip_prefix("restart-")?;
            if number.len() < 6 || !number.bytes().all(|b| b.is_ascii_digit()) {
                return None;
            }
            let path = entry.path();
            path.join(FILE_NAME)
                .is_file()
                .then(|| (number.parse().ok(), path))
                .and_then(|(n, p)| n.map(|n| (n, p)))
        })
        .collect();
    found.sort();
    found
}

/// Writes `snapshot` as restart directory `number` in `dir`: under a temporary name first,
/// renamed when complete; then removes all but the [`KEEP`] newest directories. Returns the
/// directory.
pub fn write_directory(
    dir: &Path,
    number: u64,
    snapshot: &Snapshot,
) -> Result<PathBuf, RestartError> {
    let target = directory(dir, number);
    let partial = dir.join(format!(".restart-{number:06}.partial"));
    let io = |path: &Path, action: &'static str| {
        let path = path.to_path_buf();
        move |source| RestartError::Io {
            path,
            action,
            source,
        }
    };
    if partial.exists() {
        std::fs::remove_dir_all(&partial).map_err(io(&partial, "cannot remove"))?;
    }
    std::fs::create_dir_all(&partial).map_err(io(&partial, "cannot create"))?;
    write(&partial.join(FILE_NAME), snapshot)?;
    if target.exists() {
        std::fs::remove_dir_all(&target).map_err(io(&target, "cannot replace"))?;
    }
    std::fs::rename(&partial, &target).map_err(io(&target, "cannot rename into place"))?;
    let found = directories(dir);
    for (_, old) in found.iter().take(found.len().saturating_sub(KEEP)) {
        std::fs::remove_dir_all(old).map_err(io(old, "cannot remove an old restart"))?;
    }
    Ok(target)
}

/// 64-bit FNV-1a: a stable hash (the same on every machine and build, unlike the standard
/// library's), enough to tell a changed deck from an unchanged one.
#[derive(Debug, Clone, Copy)]
pub struct Fnv(u64);

impl Default for Fnv {
    fn default() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv {
    /// Adds `bytes`.
    pub fn add(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    /// The hash so far.
    pub fn finish(self) -> u64 {
        self.0
    }
}

/// Hash of what defines the body and its physics: the deck's materials, damage models,
/// blocks, contact and boundary conditions (with file names relative to the deck, so the same
/// deck run from another folder hashes alike), and the model's points (original order:
/// position, volume, block, horizon) and bonds. A restart file whose hash differs was written
/// for another body and is refused.
pub fn model_hash(deck: &crate::io::deck::Deck, model: &Model) -> u64 {
    let mut hash = Fnv::default();
    let deck_dir = deck.directory().display().to_string();
    let text = format!(
        "{:?}{:?}{:?}{:?}{:?}",
        deck.materials, deck.damage_models, deck.blocks, deck.contact, deck.boundary_conditions
    );
    let text = if deck_dir.is_empty() {
        text
    } else {
        text.replace(&deck_dir, "")
    };
    hash.add(text.as_bytes());
    let points = &model.points;
    for &p in &model.run_index {
        let p = p as usize;
        for x in points.position[p] {
            hash.add(&x.to_le_bytes());
        }
        hash.add(&points.volume[p].to_le_bytes());
        hash.add(&points.block[p].to_le_bytes());
        hash.add(&model.horizon[p].to_le_bytes());
    }
    let order = BondOrder::of(model);
    for &bond in &order.run_bond {
        hash.add(&BondOrder::other_end(model, bond).to_le_bytes());
    }
    hash.finish()
}

/// Hash of the deck's solver lists: a restart written inside a list continues that list only
/// when the lists are unchanged.
pub fn solvers_hash(deck: &crate::io::deck::Deck) -> u64 {
    let mut hash = Fnv::default();
    hash.add(format!("{:?}", deck.solvers).as_bytes());
    hash.finish()
}

/// The bonds in original order: by the original id of the owning point, then of the other
/// end. `run_bond[k]` is the run-order bond index of the k-th bond in that order.
#[derive(Debug, Clone)]
pub struct BondOrder {
    /// Run-order bond index of each bond in original order.
    pub run_bond: Vec<usize>,
}

impl BondOrder {
    /// The order of `model`'s bonds.
    pub fn of(model: &Model) -> Self {
        let original = &model.points.original_id;
        let mut run_bond = Vec::with_capacity(model.bonds.num_bonds());
        for &p in &model.run_index {
            let range = model.bonds.range(p as usize);
            let family = model.bonds.family(p as usize);
            let mut local: Vec<usize> = (0..family.len()).collect();
            local.sort_by_key(|&j| original[family[j] as usize]);
            run_bond.extend(local.into_iter().map(|j| range.start + j));
        }
        Self { run_bond }
    }

    /// Original id of the far end of run-order bond `run_bond`.
    fn other_end(model: &Model, run_bond: usize) -> u32 {
        model.points.original_id[model.bonds.neighbor[run_bond] as usize]
    }
}

/// Values per run-order point → original order.
pub fn points_to_original<T: Copy>(model: &Model, run: &[T], width: usize) -> Vec<T> {
    let mut out = Vec::with_capacity(run.len());
    for &p in &model.run_index {
        let p = p as usize;
        out.extend_from_slice(&run[p * width..(p + 1) * width]);
    }
    out
}

/// Values per original-order point → run order (into `run`).
pub fn points_to_run<T: Copy>(model: &Model, original: &[T], run: &mut [T], width: usize) {
    for (k, &p) in model.run_index.iter().enumerate() {
        let p = p as usize;
        run[p * width..(p + 1) * width].copy_from_slice(&original[k * width..(k + 1) * width]);
    }
}

/// Values per run-order bond → original order.
pub fn bonds_to_original<T: Copy>(order: &BondOrder, run: &[T], width: usize) -> Vec<T> {
    let mut out = Vec::with_capacity(run.len());
    for &b in &order.run_bond {
        out.extend_from_slice(&run[b * width..(b + 1) * width]);
    }
    out
}

/// Values per original-order bond → run order (into `run`).
pub fn bonds_to_run<T: Copy>(order: &BondOrder, original: &[T], run: &mut [T], width: usize) {
    for (k, &b) in order.run_bond.iter().enumerate() {
        run[b * width..(b + 1) * width].copy_from_slice(&original[k * width..(k + 1) * width]);
    }
}
