//! `peridyn dogbone`: the tensile-test specimen of Littlewood's "Roadmap for Software
//! Implementation" (2016, §18.8.2) as a `Text File` discretization with node sets and a deck,
//! at a chosen approximate point count.
//!
//! `peridyn dogbone --points 99000 --output-dir big` writes the paper's size. The output is a
//! function of the arguments alone (no randomness, no clock), so the same command gives the
//! same bytes. Geometry: [`geometry`]; lattice and volumes: [`lattice`]; deck: [`deck`].

mod deck;
mod geometry;
mod lattice;

use std::path::{Path, PathBuf};

use deck::{DeckNames, Specimen, GAUGE_HALF_LENGTH};
use geometry::DogBone;

/// Fewest points: below this the gauge section is less than three cells wide.
pub const MIN_POINTS: usize = 500;

/// Most points: beyond this the lattice alone would take gigabytes, and a run of it (about
/// 60 bonds and 2 kB of state and bonds per point) more memory than any one machine has.
pub const MAX_POINTS: usize = 50_000_000;

/// Command-line options of `peridyn dogbone`.
#[derive(Debug, Clone, clap::Args)]
pub struct DogboneArgs {
    /// Approximate number of points (the lattice spacing is chosen to come nearest).
    #[arg(long, default_value_t = 5000)]
    pub points: usize,
    /// Folder for the files (created if missing).
    #[arg(long, default_value = ".")]
    pub output_dir: PathBuf,
    /// Base name of the files: `<name>.yaml`, `<name>.txt`, `<name>_*_grip.txt`, …
    #[arg(long, default_value = "dogbone")]
    pub name: String,
}

/// Why the specimen was not written.
#[derive(Debug, thiserror::Error)]
pub enum DogboneError {
    /// A command-line value is out of range.
    #[error("peridyn dogbone: {0}")]
    Options(String),
    /// A file or the folder cannot be written.
    #[error("{path}: cannot write: {source}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
}

/// The specimen at the spacing whose point count is nearest `target`.
pub fn specimen(target: usize) -> Specimen {
    let bone = DogBone::ROADMAP;
    let spacing = lattice::spacing_for(&bone, target);
    let points = lattice::points(&bone, spacing);
    let grip_edge = bone.length / 2.0 - bone.grip_length;
    let blocks = points
        .iter()
        .map(|p| match p.position[1] {
            y if y <= -grip_edge => 1,
            y if y >= grip_edge => 3,
            _ => 2,
        })
        .collect();
    Specimen {
        points,
        blocks,
        spacing,
    }
}

fn write(path: &Path, text: &str) -> Result<(), DogboneError> {
    std::fs::write(path, text).map_err(|source| DogboneError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Writes the discretization, node sets and deck; returns a summary for the terminal.
pub fn main(args: &DogboneArgs) -> Result<String, DogboneError> {
    if args.points < MIN_POINTS {
        return Err(DogboneError::Options(format!(
            "--points {} is too few; at least {MIN_POINTS}",
            args.points
        )));
    }
    if args.points > MAX_POINTS {
        return Err(DogboneError::Options(format!(
            "--points {} is too many; at most {MAX_POINTS}",
            args.points
        )));
    }
    if args.name.is_empty() || args.name.contains(['/', '\\', '"']) {
        return Err(DogboneError::Options(format!(
            "--name {:?} must be a plain file name",
            args.name
        )));
    }
    std::fs::create_dir_all(&args.output_dir).map_err(|source| DogboneError::Io {
        path: args.output_dir.clone(),
        source,
    })?;
    let specimen = specimen(args.points);
    let sets = specimen.node_sets();
    let name = &args.name;
    let file = |suffix: &str| args.output_dir.join(format!("{name}{suffix}"));
    write(&file(".txt"), &specimen.text_file())?;
    for (suffix, ids) in [
        ("_bottom_grip.txt", &sets.bottom_grip),
        ("_top_grip.txt", &sets.top_grip),
        ("_bottom_hold_x.txt", &sets.bottom_hold_x),
        ("_bottom_hold_z.txt", &sets.bottom_hold_z),
        ("_top_hold_x.txt", &sets.top_hold_x),
        ("_top_hold_z.txt", &sets.top_hold_z),
    ] {
        write(&file(suffix), &deck::node_set_file(ids))?;
    }
    let top = specimen.nearest([0.0, GAUGE_HALF_LENGTH, 0.0]);
    let bottom = specimen.nearest([0.0, -GAUGE_HALF_LENGTH, 0.0]);
    let mut command = format!("peridyn dogbone --points {}", args.points);
    if name != "dogbone" {
        command.push_str(&format!(" --name {name}"));
    }
    let names = DeckNames {
        name,
        command: &command,
        points: specimen.points.len(),
        spacing: specimen.spacing,
        gauge: [
            specimen.points[top].position,
            specimen.points[bottom].position,
        ],
    };
    write(&file(".yaml"), &deck::deck(&names))?;
    Ok(format!(
        "wrote {}: {} points (asked for {}), spacing {:.6}, horizon {:.6}, grips {} + {} points\n",
        file(".yaml").display(),
        specimen.points.len(),
        args.points,
        specimen.spacing,
        deck::HORIZON_PER_SPACING * specimen.spacing,
        sets.bottom_grip.len(),
        sets.top_grip.len()
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn point_count_is_near_the_request_and_volume_exact() {
        for target in [2000, 5000] {
            let specimen = specimen(target);
            let count = specimen.points.len();
            assert!(
                count.abs_diff(target) as f64 <= 0.03 * target as f64,
                "{target}: {count}"
            );
            let total: f64 = specimen.points.iter().map(|p| p.volume).sum();
            let exact = DogBone::ROADMAP.volume();
            assert!((total / exact - 1.0).abs() < 0.01, "{total} vs {exact}");
        }
    }

    #[test]
    fn node_sets_are_lines_and_grips() {
        let specimen = specimen(5000);
        let sets = specimen.node_sets();
        for set in [
            &sets.bottom_grip,
            &sets.top_grip,
            &sets.bottom_hold_x,
            &sets.bottom_hold_z,
            &sets.top_hold_x,
            &sets.top_hold_z,
        ] {
            assert!(!set.is_empty());
        }
        assert_eq!(sets.bottom_grip.len(), sets.top_grip.len());
        // A line held in x runs through the thickness: one point per layer, at one x.
        let layers = specimen.points.iter().map(|p| p.cell[2]).max().unwrap() + 1;
        assert_eq!(sets.bottom_hold_x.len(), layers);
        let xs: Vec<f64> = sets
            .bottom_hold_x
            .iter()
            .map(|&p| specimen.points[p].position[0])
            .collect();
        assert!(xs.iter().all(|&x| x == xs[0]));
        let top = specimen.nearest([0.0, GAUGE_HALF_LENGTH, 0.0]);
        assert!((specimen.points[top].position[1] - GAUGE_HALF_LENGTH).abs() <= specimen.spacing);
    }

    #[test]
    fn large_specimens_get_the_jacobian_free_multigrid_solver() {
        let names = |points| deck::DeckNames {
            name: "bone",
            command: "peridyn dogbone",
            points,
            spacing: 0.1,
            gauge: [[0.0, 1.27, 0.0], [0.0, -1.27, 0.0]],
        };
        let small = deck::deck(&names(deck::JACOBIAN_FREE_ABOVE_POINTS));
        assert!(small.contains("    QuasiStatic:"), "{small}");
        assert!(!small.contains("AMG"));
        let large = deck::deck(&names(deck::JACOBIAN_FREE_ABOVE_POINTS + 1));
        for key in [
            "Peridigm Preconditioner: \"AMG\"",
            "Jacobian Operator: \"Matrix-Free\"",
            "    NOXQuasiStatic:",
        ] {
            assert!(large.contains(key), "{key} missing in\n{large}");
        }
    }
}
