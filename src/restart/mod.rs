//! Restart files: where a run stands, written so that a later run continues it bit for bit,
//! on the same number of ranks or another.
//!
//! A [`Snapshot`] holds everything of a run that evolves ([`crate::state::State`]: u, v, a,
//! forces, current positions, bond damage, every staged history field, contact's last
//! search) and where the run is in its deck (solver list, step, time, the quasi-static load
//! schedule with its cuts, the stability monitor, the output frame counters), plus two
//! hashes of the deck: one of the body and its physics, one of the solver lists.
//!
//! Points and bonds are stored in the user's original order (bonds by the original ids of
//! their two ends, [`BondStructure`]), never in run order, so that a file depends neither on
//! the renumbering nor on the partition: a file written by a run on N ranks is the file one
//! rank writes, and any number of ranks reads it. With the `hdf5` feature a snapshot is one
//! HDF5 file, `restart-NNNNNN/restart.h5` in the output folder ([`directory`]); without it
//! every deck that asks for restart is refused by `peridyn check` and `peridyn run` alike.
//!
//! # On N ranks: rank 0 gathers, every rank reads
//! Each rank [`capture`]s the [`Share`] of its owned points (their original ids, their point
//! values, their rows of bonds sorted by the far end's original id) and [`gather`] collects
//! the shares on rank 0 in original order; rank 0 alone writes the file, through the same
//! serial HDF5 writer one rank uses. To continue, every rank reads the whole file and takes the
//! values of its own points, owned and ghosts ([`apply`]). One rank runs the same code with
//! every point owned and no messages.
//!
//! Why not parallel HDF5 (every rank writing its slab of one file through MPI-IO): Debian 12
//! ships the serial library (`libhdf5-dev`) and the MPI one (`libhdf5-openmpi-dev`) as two
//! flavours of which pkg-config finds one; hdf5-metno's `mpio` feature needs the MPI flavour in
//! every build with `hdf5`, the one-process builds without `mpi` included, and the MPI
//! flavour's library needs MPI initialised before any file is opened, which one-process runs
//! do not do. Gathering on rank 0 keeps one library and one writer for every build. Its costs:
//! while a file is written rank 0 holds the whole snapshot (the state of every point and bond,
//! about what one rank holds for the whole body), and while a run resumes every rank holds the
//! whole file once. Every rank reads the file, so the output folder must be on a file system
//! that every rank sees (as on clusters, and on one machine).
//!
//! Restart directories are numbered as Peridigm numbers them (`restart-000001`, …); a run
//! resumes from the highest number. A directory is written under a temporary name and renamed
//! when complete, so a run killed while writing leaves the previous one intact; only the two
//! newest are kept.

mod capture;
mod gather;
#[cfg(feature = "hdf5")]
mod hdf5_file;
#[cfg(test)]
mod tests;

pub use capture::{apply, capture, restore_contact, ContactRestore, Share};
pub use gather::{gather, gather_bonds};

use crate::model::Model;
use std::path::{Path, PathBuf};

/// Version of the snapshot layout; a file of another version is refused. Version 2 added the
/// bond structure ([`BondStructure`]) and the contact points' ids, which a run on N ranks needs
/// to find the values of its points.
pub const FORMAT_VERSION: u64 = 2;

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

/// The bonds of the body in original order: the rows of the points by original id, each row
/// by the original id of its far end. Bond fields of a [`Snapshot`] follow this order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BondStructure {
    /// Bonds of every point (original order).
    pub family_size: Vec<u32>,
    /// Original id of the far end of every bond.
    pub neighbor: Vec<u32>,
}

impl BondStructure {
    /// Offset of every point's row (original order), with the bond count at the end.
    pub fn offsets(&self) -> Vec<usize> {
        let mut offsets = Vec::with_capacity(self.family_size.len() + 1);
        offsets.push(0);
        for &size in &self.family_size {
            offsets.push(offsets[offsets.len() - 1] + size as usize);
        }
        offsets
    }
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
    /// Original ids of the contact points, ascending: the order of `searched_at`.
    pub points: Vec<u32>,
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
    /// The bonds, in the order of every bond field.
    pub bonds: BondStructure,
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
/// deck run from another folder hashes alike), the points of `global` (the whole model, in
/// original order: position, volume, block, horizon) and its bonds (`bonds`, the far ends in
/// original order, [`BondStructure`]). A restart file whose hash differs was written for
/// another body and is refused. The hash does not depend on the number of ranks.
pub fn model_hash(deck: &crate::io::deck::Deck, global: &Model, bonds: &BondStructure) -> u64 {
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
    let points = &global.points;
    for &p in &global.run_index {
        let p = p as usize;
        for x in points.position[p] {
            hash.add(&x.to_le_bytes());
        }
        hash.add(&points.volume[p].to_le_bytes());
        hash.add(&points.block[p].to_le_bytes());
        hash.add(&global.horizon[p].to_le_bytes());
    }
    for &far in &bonds.neighbor {
        hash.add(&far.to_le_bytes());
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
