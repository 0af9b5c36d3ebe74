//! The run plan: what a deck asks for, what will exist, and what it costs.
//!
//! `peridyn check` prints it; `peridyn run` builds exactly what it lists, and nothing more: no
//! contact search, damage array, tangent, halo or output field unless the deck needs it.

use serde::Serialize;
use std::fmt;

/// Everything `peridyn check` reports about a deck. Serialised as the `--json` object.
#[derive(Debug, Clone, Default, Serialize)]
pub struct RunPlan {
    /// The deck file.
    pub deck: String,
    /// Discretization type as written (`PdQuickGrid`, `Text File`, `Exodus`).
    pub discretization: String,
    /// Total number of points.
    pub points: usize,
    /// Total number of directed bonds (each pair counts twice, as Peridigm stores them).
    pub bonds: usize,
    /// Per-block summary.
    pub blocks: Vec<BlockPlan>,
    /// Node sets with their sizes (deck and mesh sets).
    pub node_sets: Vec<NodeSetPlan>,
    /// Physics that will run.
    pub physics: PhysicsPlan,
    /// Fields that will be allocated, with their memory.
    pub fields: Vec<FieldPlan>,
    /// Estimated memory per part, bytes.
    pub memory: Vec<MemoryPlan>,
    /// Total estimated memory, bytes.
    pub memory_total: u64,
    /// `memory_total` divided by the directed bonds (per-point data included), bytes; `None`
    /// without bonds. An explicit PMB run's resident memory is close to this
    /// (`peridyn bench` prints both).
    pub bytes_per_bond: Option<f64>,
    /// Explicit time-step estimate (Peridigm's formula), when an explicit solver is present.
    pub time_step: Option<TimeStepPlan>,
    /// Solvers in the order they run.
    pub solvers: Vec<SolverPlan>,
    /// Output files.
    pub outputs: Vec<OutputPlan>,
    /// What a run on several MPI ranks would hold and exchange.
    pub parallel: ParallelPlan,
    /// Features in the deck that this build cannot run yet (empty when the deck runs).
    pub unsupported: Vec<String>,
    /// Deck keys that are accepted but have no effect, and other notes.
    pub warnings: Vec<String>,
    /// What the run will write against the free space of its output folder.
    pub disk: Option<DiskPlan>,
}

/// The volume a run will write and the free space of its output folder's file system
/// ([`crate::setup::disk`] says how it is estimated).
#[derive(Debug, Clone, Default, Serialize)]
pub struct DiskPlan {
    /// The output folder.
    pub folder: String,
    /// Estimated bytes of the Exodus results files.
    pub results_bytes: u64,
    /// Estimated bytes of the restart files that can exist at once (0 without restart).
    pub restart_bytes: u64,
    /// Bytes free for this user on the folder's file system (`statvfs`), when known.
    pub available_bytes: Option<u64>,
}

/// One block of points.
#[derive(Debug, Clone, Default, Serialize)]
pub struct BlockPlan {
    /// `block_<id>`.
    pub name: String,
    /// Mesh block id.
    pub id: i64,
    /// Material name from the deck and its model.
    pub material: String,
    /// `Material Model` string.
    pub material_model: String,
    /// Damage model name, if any.
    pub damage_model: Option<String>,
    /// Number of points.
    pub points: usize,
    /// Directed bonds starting in this block.
    pub bonds: usize,
    /// Smallest family size.
    pub family_min: usize,
    /// Largest family size.
    pub family_max: usize,
    /// Mean family size.
    pub family_mean: f64,
    /// Smallest horizon of the block's points.
    pub horizon_min: f64,
    /// Largest horizon of the block's points.
    pub horizon_max: f64,
    /// The block's quadrature rule and what it gives, when not the full volume (the
    /// `Blocks → … → Quadrature` line of `peridyn check`).
    pub quadrature: Option<String>,
    /// The block's surface correction and the factors it gave, when the block has one (the
    /// `Blocks → … → Surface Correction` line of `peridyn check`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub surface_correction: Option<String>,
}

/// One node set.
#[derive(Debug, Clone, Default, Serialize)]
pub struct NodeSetPlan {
    /// Name as written.
    pub name: String,
    /// Number of points.
    pub points: usize,
    /// `deck` or `mesh`.
    pub source: String,
}

/// Which physics run.
#[derive(Debug, Clone, Default, Serialize)]
pub struct PhysicsPlan {
    /// Any state-based material (a per-point pass before the forces: the LPS dilatation, a
    /// correspondence deformation gradient and stress).
    pub state_based: bool,
    /// Any block with a damage model (allocates bond damage).
    pub damage: bool,
    /// A `Contact` section exists (proximity search).
    pub contact: bool,
    /// An explicit (Verlet) solver is present.
    pub explicit: bool,
    /// An implicit solver is present (tangent needed).
    pub implicit: bool,
    /// Tangent sparsity pattern when implicit: `one-hop` (bond-based) or `two-hop` (state-based).
    pub tangent_pattern: Option<String>,
}

/// One allocated field.
#[derive(Debug, Clone, Default, Serialize)]
pub struct FieldPlan {
    /// Field name (Peridigm's output name where one exists).
    pub name: String,
    /// `point` or `bond`.
    pub per: String,
    /// Bytes.
    pub bytes: u64,
}

/// Memory of one part of the run.
#[derive(Debug, Clone, Default, Serialize)]
pub struct MemoryPlan {
    /// Part name.
    pub part: String,
    /// Bytes.
    pub bytes: u64,
}

/// A run on several MPI ranks (`mpirun -np N`, feature `mpi`): ghosts, the per-point data
/// that moves between ranks, and where the families come from.
#[derive(Debug, Clone, Default, Serialize)]
pub struct ParallelPlan {
    /// Ghost layers in bonds: 1 when every force and damage decision reads only a bond's two
    /// ends, 2 when state-based materials read their neighbours' dilatation.
    pub ghost_depth: usize,
    /// The data exchanged, one entry per kind, with when it moves. Everything else a ghost
    /// needs (damage, dilatation, weighted volume) is recomputed on it, not sent.
    pub exchanged: Vec<String>,
    /// `searched per rank` (no rank holds the global bond list) or why every rank holds it.
    pub families: String,
    /// Why the deck cannot run on several ranks, when it cannot.
    pub refused: Option<String>,
    /// How each solver list on the PETSc backend runs on several ranks (`Solver: PETSc KSP cg +
    /// PC bjacobi on MPI_COMM_WORLD …`), the resolved solver and what its preconditioner does
    /// with each rank's rows.
    pub solvers: Vec<String>,
}

/// The explicit stable time step.
#[derive(Debug, Clone, Default, Serialize)]
pub struct TimeStepPlan {
    /// Δt = min_i sqrt(2ρ / Σ_j V_j c/ζ_ij), c = 18K/(πδ⁴) (Peridigm's estimate), seconds.
    pub estimate: f64,
    /// `Safety Factor` of the first Verlet solver (default 1).
    pub safety_factor: f64,
    /// `Fixed dt` if given.
    pub fixed: Option<f64>,
    /// The Δt the first Verlet solver will use.
    pub used: f64,
    /// Steps of the first Verlet solver: floor((t_final − t_initial)/Δt).
    pub steps: u64,
}

/// One solver list.
#[derive(Debug, Clone, Default, Serialize)]
pub struct SolverPlan {
    /// List name in the deck (`Solver`, `Solver1`, …).
    pub name: String,
    /// Integrator (`Verlet`, `QuasiStatic`, `NOXQuasiStatic`, `Implicit`, `ImplicitDiffusion`).
    pub kind: String,
    /// `Initial Time`.
    pub initial_time: f64,
    /// `Final Time`.
    pub final_time: f64,
    /// The solver the PETSc backend resolved from the deck's keys and `PETSc Options` (e.g.
    /// `PETSc KSP cg + PC gamg`), or the linear strategy of peridyn's Newton on the native
    /// backend (e.g. `native CG + block 3x3`); `None` for explicit lists and NOX.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub resolved: Option<String>,
    /// What the list does with a step that fails or breaks too many bonds (cuts, dynamic
    /// relaxation, `Switch to Verlet`), one line each.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub step_strategy: Vec<String>,
}

/// One output file.
#[derive(Debug, Clone, Default, Serialize)]
pub struct OutputPlan {
    /// Output list name in the deck.
    pub name: String,
    /// File name written (`<Output Filename>.e`).
    pub file: String,
    /// `Output Frequency`.
    pub frequency: i64,
    /// Requested variables, in deck order.
    pub variables: Vec<String>,
}

/// The memory this process may use, in bytes: the least of the machine's memory (`MemTotal`
/// of `/proc/meminfo`), the process's address-space limit (`ulimit -v`, read from
/// `/proc/self/limits`) and the memory limit of its control group (cgroup v2 `memory.max`,
/// which batch schedulers such as SLURM set per job); `None` where none can be read (not
/// Linux). The size guards compare their estimates with it, so a job is refused before it
/// starts rather than killed for memory midway.
pub fn usable_memory_bytes() -> Option<u64> {
    [
        machine_memory(),
        address_space_limit(),
        control_group_limit(),
    ]
    .into_iter()
    .flatten()
    .min()
}

/// `MemTotal` of `/proc/meminfo`, in bytes.
fn machine_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

/// The soft limit of `Max address space` in `/proc/self/limits` (bytes; `None` when
/// unlimited).
fn address_space_limit() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = text.lines().find(|l| l.starts_with("Max address space"))?;
    let soft = line
        .trim_start_matches("Max address space")
        .split_whitespace()
        .next()?;
    soft.parse().ok()
}

/// `memory.max` of this process's cgroup v2 (the `0::PATH` line of `/proc/self/cgroup`), in
/// bytes; `None` when it is `max`, or the system has no cgroup v2.
fn control_group_limit() -> Option<u64> {
    let groups = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let path = groups.lines().find_map(|l| l.strip_prefix("0::"))?;
    let file = format!("/sys/fs/cgroup{}/memory.max", path.trim_end_matches('/'));
    std::fs::read_to_string(file).ok()?.trim().parse().ok()
}

/// Human-readable byte count.
pub fn format_bytes(bytes: u64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut value = bytes as f64;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < UNITS.len() {
        value /= 1024.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{bytes} B")
    } else {
        format!("{value:.1} {}", UNITS[unit])
    }
}

impl fmt::Display for RunPlan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "deck            {}", self.deck)
            .and_then(|_| writeln!(f, "discretization  {}", self.discretization))?;
        writeln!(f, "points          {}", self.points)?;
        writeln!(f, "bonds           {} (directed)", self.bonds)?;
        self.fmt_blocks(f)?;
        if !self.node_sets.is_empty() {
            writeln!(f, "\nnode sets")?;
            for s in &self.node_sets {
                writeln!(f, "  {:<32} {:>9} points  ({})", s.name, s.points, s.source)?;
            }
        }
        self.fmt_physics(f)?;
        self.fmt_storage(f)?;
        self.fmt_time(f)?;
        self.fmt_parallel(f)?;
        if let Some(disk) = &self.disk {
            writeln!(f, "\ndisk ({})", disk.folder)?;
            writeln!(
                f,
                "  results (estimate)  {}",
                format_bytes(disk.results_bytes)
            )?;
            if disk.restart_bytes > 0 {
                writeln!(
                    f,
                    "  restart (estimate)  {}",
                    format_bytes(disk.restart_bytes)
                )?;
            }
            match disk.available_bytes {
                Some(bytes) => writeln!(f, "  free                {}", format_bytes(bytes))?,
                None => writeln!(f, "  free                unknown")?,
            }
        }
        for w in &self.warnings {
            writeln!(f, "\nwarning: {w}")?;
        }
        if !self.unsupported.is_empty() {
            writeln!(f, "\nnot supported by this build yet:")?;
            for u in &self.unsupported {
                writeln!(f, "  - {u}")?;
            }
        }
        Ok(())
    }
}

impl DiskPlan {
    /// The warning a run plan carries when the run will not fit in the free space.
    pub fn warning(&self) -> Option<String> {
        let disk = self;
        let needed = disk.results_bytes.saturating_add(disk.restart_bytes);
        let available = disk.available_bytes?;
        (needed > available).then(|| {
            format!(
                "the run will write about {} ({} of results{}) but only {} is free on the file system of {}: it would stop with exit code 6 when the disk is full. Free space, give --output-dir another file system, or write fewer frames (Output Frequency) or variables",
                format_bytes(needed),
                format_bytes(disk.results_bytes),
                if disk.restart_bytes > 0 {
                    format!(", {} of restart files", format_bytes(disk.restart_bytes))
                } else {
                    String::new()
                },
                format_bytes(available),
                disk.folder
            )
        })
    }
}

impl RunPlan {
    /// The plan with its disk section, and the warning when the run will not fit.
    pub fn with_disk(mut self, disk: DiskPlan) -> Self {
        if let Some(warning) = disk.warning() {
            self.warnings.push(warning);
        }
        self.disk = Some(disk);
        self
    }

    /// The `blocks` section: sizes, families, horizon, material and damage of every block.
    fn fmt_blocks(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "\nblocks")?;
        for b in &self.blocks {
            writeln!(
                f,
                "  {:<12} id {:<4} {:>9} points {:>11} bonds  family min/max/mean {}/{}/{:.2}  horizon {}",
                b.name,
                b.id,
                b.points,
                b.bonds,
                b.family_min,
                b.family_max,
                b.family_mean,
                if b.horizon_min == b.horizon_max {
                    format!("{}", b.horizon_min)
                } else {
                    format!("{}..{}", b.horizon_min, b.horizon_max)
                }
            )?;
            writeln!(
                f,
                "  {:<12} material \"{}\" ({}){}",
                "",
                b.material,
                b.material_model,
                b.damage_model
                    .as_ref()
                    .map(|d| format!(", damage \"{d}\""))
                    .unwrap_or_default()
            )?;
            if let Some(quadrature) = &b.quadrature {
                writeln!(f, "  {:<12} quadrature {quadrature}", "")?;
            }
            if let Some(correction) = &b.surface_correction {
                writeln!(f, "  {:<12} surface correction {correction}", "")?;
            }
        }
        Ok(())
    }

    /// The `physics` section: which passes the run makes.
    fn fmt_physics(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let p = &self.physics;
        let yes = |b: bool| if b { "yes" } else { "no" };
        writeln!(f, "\nphysics")?;
        writeln!(f, "  state-based point pass       {}", yes(p.state_based))?;
        writeln!(f, "  bond damage                  {}", yes(p.damage))?;
        writeln!(f, "  contact search               {}", yes(p.contact))?;
        writeln!(f, "  explicit dynamics            {}", yes(p.explicit))?;
        writeln!(
            f,
            "  implicit (tangent)           {}",
            p.tangent_pattern
                .as_ref()
                .map(|t| format!("yes, {t} pattern"))
                .unwrap_or_else(|| "no".into())
        )
    }

    /// The `fields` and `memory (estimate)` sections.
    fn fmt_storage(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "\nfields")?;
        for field in &self.fields {
            writeln!(
                f,
                "  {:<28} per {:<5} {:>10}",
                field.name,
                field.per,
                format_bytes(field.bytes)
            )?;
        }
        writeln!(f, "\nmemory (estimate)")?;
        for m in &self.memory {
            writeln!(f, "  {:<28} {:>10}", m.part, format_bytes(m.bytes))?;
        }
        writeln!(
            f,
            "  {:<28} {:>10}",
            "total",
            format_bytes(self.memory_total)
        )?;
        match self.bytes_per_bond {
            Some(bytes) => writeln!(f, "  {:<28} {:>8.1} B", "per directed bond", bytes),
            None => Ok(()),
        }
    }

    /// The `explicit time step`, `solvers` and `outputs` sections.
    fn fmt_time(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(dt) = &self.time_step {
            writeln!(f, "\nexplicit time step")?;
            writeln!(f, "  stable estimate   {:e} s", dt.estimate)?;
            writeln!(f, "  safety factor     {}", dt.safety_factor)?;
            if let Some(fixed) = dt.fixed {
                writeln!(f, "  fixed dt          {fixed:e} s")?;
            }
            writeln!(
                f,
                "  time step used    {:e} s ({} steps)",
                dt.used, dt.steps
            )?;
        }
        writeln!(f, "\nsolvers")?;
        for s in &self.solvers {
            writeln!(
                f,
                "  {:<12} {:<16} t = {} → {}",
                s.name, s.kind, s.initial_time, s.final_time
            )?;
            if let Some(resolved) = &s.resolved {
                writeln!(f, "  {:<12} {resolved}", "")?;
            }
            for line in &s.step_strategy {
                writeln!(f, "  {:<12} {line}", "")?;
            }
        }
        if !self.outputs.is_empty() {
            writeln!(f, "\noutputs")?;
            for o in &self.outputs {
                writeln!(
                    f,
                    "  {:<24} every {} step(s): {}",
                    o.file,
                    o.frequency,
                    o.variables.join(", ")
                )?;
            }
        }
        Ok(())
    }

    /// The `on several MPI ranks` section.
    fn fmt_parallel(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let p = &self.parallel;
        writeln!(f, "\non several MPI ranks")?;
        match &p.refused {
            Some(why) => writeln!(f, "  refused: {why}")?,
            None => {
                writeln!(f, "  ghost depth      {} bond(s)", p.ghost_depth)?;
                for data in &p.exchanged {
                    writeln!(f, "  exchanged        {data}")?;
                }
                writeln!(f, "  families         {}", p.families)?;
                for solver in &p.solvers {
                    writeln!(f, "  solver           {solver}")?;
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_are_formatted_in_binary_units() {
        assert_eq!(format_bytes(512), "512 B");
        assert_eq!(format_bytes(1536), "1.5 KiB");
        assert_eq!(format_bytes(3 * 1024 * 1024), "3.0 MiB");
    }
}
