//! The files of a generated dog-bone: the `Text File` discretization, node-set files, and a
//! deck in the style of Peridigm's `tensile_test.yaml`.

use super::lattice::LatticePoint;

/// Horizon over lattice spacing (Peridigm's example uses about 2.5 of its element size; the
/// customary 3 for lattices, a little over so spheres do not cut lattice shells by round-off).
pub const HORIZON_PER_SPACING: f64 = 3.015;

/// Height of the gauge points above and below the middle: half of a 1-inch (2.54 cm) gauge.
pub const GAUGE_HALF_LENGTH: f64 = 1.27;

/// The discretization and the points the deck names.
#[derive(Debug, Clone)]
pub struct Specimen {
    /// Points with their volumes.
    pub points: Vec<LatticePoint>,
    /// Block id (1 bottom grip, 2 the bar between, 3 top grip) per point.
    pub blocks: Vec<u32>,
    /// Lattice spacing.
    pub spacing: f64,
}

/// The node sets of the deck: (file suffix, 0-based point ids).
pub struct NodeSets {
    /// Bottom grip (block 1), pulled down.
    pub bottom_grip: Vec<usize>,
    /// Top grip (block 3), pulled up.
    pub top_grip: Vec<usize>,
    /// The bottom end's line along z at its smallest x: held in x.
    pub bottom_hold_x: Vec<usize>,
    /// The bottom end's line along x at its smallest z: held in z.
    pub bottom_hold_z: Vec<usize>,
    /// The top end's line along z at its smallest x: held in x.
    pub top_hold_x: Vec<usize>,
    /// The top end's line along x at its smallest z: held in z.
    pub top_hold_z: Vec<usize>,
}

impl Specimen {
    /// The points of the end row `row` (y cell index) on the line where the other two cell
    /// indices take their smallest values but `along`'s (0 = x, 2 = z).
    fn end_line(&self, row: usize, along: usize) -> Vec<usize> {
        let fixed = 2 - along;
        let end: Vec<usize> = (0..self.points.len())
            .filter(|&p| self.points[p].cell[1] == row)
            .collect();
        let lowest = end.iter().map(|&p| self.points[p].cell[fixed]).min();
        end.into_iter()
            .filter(|&p| Some(self.points[p].cell[fixed]) == lowest)
            .collect()
    }

    /// The node sets of Peridigm's example: both grips, and at each end one line held in x
    /// and one held in z (with the prescribed y, no rigid-body motion is left).
    pub fn node_sets(&self) -> NodeSets {
        let in_block = |id: u32| -> Vec<usize> {
            (0..self.points.len())
                .filter(|&p| self.blocks[p] == id)
                .collect()
        };
        let last_row = self.points.iter().map(|p| p.cell[1]).max().unwrap_or(0);
        let first_row = self.points.iter().map(|p| p.cell[1]).min().unwrap_or(0);
        NodeSets {
            bottom_grip: in_block(1),
            top_grip: in_block(3),
            bottom_hold_x: self.end_line(first_row, 2),
            bottom_hold_z: self.end_line(first_row, 0),
            top_hold_x: self.end_line(last_row, 2),
            top_hold_z: self.end_line(last_row, 0),
        }
    }

    /// The point nearest `target` (the lowest id among equals).
    pub fn nearest(&self, target: [f64; 3]) -> usize {
        let distance =
            |p: &LatticePoint| -> f64 { (0..3).map(|a| (p.position[a] - target[a]).powi(2)).sum() };
        let mut best = 0;
        for (index, point) in self.points.iter().enumerate() {
            if distance(point) < distance(&self.points[best]) {
                best = index;
            }
        }
        best
    }

    /// The `Text File` discretization: `x y z block_id volume` per line, numbers in Rust's
    /// shortest round-trip form so the deck's gauge coordinates name points exactly.
    pub fn text_file(&self) -> String {
        let mut text = format!(
            "# dog-bone, {} points, lattice spacing {:?}: x y z block_id volume\n",
            self.points.len(),
            self.spacing
        );
        for (point, block) in self.points.iter().zip(&self.blocks) {
            let [x, y, z] = point.position;
            text.push_str(&format!("{x:?} {y:?} {z:?} {block} {:?}\n", point.volume));
        }
        text
    }
}

/// A node-set file: 1-based ids, one per line.
pub fn node_set_file(ids: &[usize]) -> String {
    ids.iter().map(|id| format!("{}\n", id + 1)).collect()
}

/// What the deck text needs besides the fixed material and solver.
pub struct DeckNames<'a> {
    /// Base name of every file (`<name>.txt`, `<name>_top_grip.txt`, `<name>.yaml`, output).
    pub name: &'a str,
    /// The command that generated the files, for the header.
    pub command: &'a str,
    /// Point count.
    pub points: usize,
    /// Lattice spacing.
    pub spacing: f64,
    /// Positions of the upper and lower gauge points.
    pub gauge: [[f64; 3]; 2],
}

/// One `Nearest_Point_Data` compute class.
fn nearest_point(title: &str, at: [f64; 3], variable: &str, label: &str) -> String {
    format!(
        "    {title}:\n      Compute Class: \"Nearest_Point_Data\"\n      X: {:?}\n      Y: {:?}\n      Z: {:?}\n      Variable: \"{variable}\"\n      Output Label: \"{label}\"\n",
        at[0], at[1], at[2]
    )
}

/// One prescribed-displacement condition.
fn prescribed(title: &str, set: &str, coordinate: &str, value: &str) -> String {
    format!(
        "    {title}:\n      Type: \"Prescribed Displacement\"\n      Node Set: \"{set}\"\n      Coordinate: \"{coordinate}\"\n      Value: \"{value}\"\n"
    )
}

/// The deck: Peridigm's tensile_test material, grips and compute classes on the generated
/// discretization; 4 quasi-static load steps to 0.5 % nominal strain of the grips.
pub fn deck(names: &DeckNames) -> String {
    let name = names.name;
    let mut text = format!(
        "# The tensile test of Littlewood's Roadmap for Software Implementation (2016, §18.8.2):
# a dog-bone in elastic correspondence, CGS units, pulled by its grips in 4 quasi-static
# load steps. Generated by `{command}`:
# {points} points on a cubic lattice of spacing {spacing:.6} cm, horizon {horizon_ratio} × spacing.
# Young's modulus per load step (gauge section 0.635 cm × 0.315 cm = 0.200025 cm²):
#   peridyn modulus {name}.csv --area 0.200025 --expected 1.8e12 --units cgs --plot {name}.png
Peridigm:
  Verbose: false
  Discretization:
    Type: \"Text File\"
    Input Mesh File: \"{name}.txt\"
  Materials:
    My Material:
      Material Model: \"Elastic Correspondence\"
      Density: 8.0
      Bulk Modulus: 1.500e12
      Shear Modulus: 6.923e11
      Hourglass Coefficient: 0.02
  Blocks:
    My Block:
      Block Names: \"block_1 block_2 block_3\"
      Material: \"My Material\"
      Horizon: {horizon:.6}
  Boundary Conditions:
    Bottom Grip Node Set: \"{name}_bottom_grip.txt\"
    Top Grip Node Set: \"{name}_top_grip.txt\"
    Bottom Line Along Z Node Set: \"{name}_bottom_hold_x.txt\"
    Bottom Line Along X Node Set: \"{name}_bottom_hold_z.txt\"
    Top Line Along Z Node Set: \"{name}_top_hold_x.txt\"
    Top Line Along X Node Set: \"{name}_top_hold_z.txt\"
",
        command = names.command,
        points = names.points,
        spacing = names.spacing,
        horizon_ratio = HORIZON_PER_SPACING,
        horizon = HORIZON_PER_SPACING * names.spacing,
    );
    text.push_str(&prescribed(
        "Prescribed Displacement Bottom",
        "Bottom Grip Node Set",
        "y",
        "y*0.005*t",
    ));
    text.push_str(&prescribed(
        "Prescribed Displacement Top",
        "Top Grip Node Set",
        "y",
        "y*0.005*t",
    ));
    text.push_str(&prescribed(
        "Fix Bottom Rigid Body Motion In X",
        "Bottom Line Along Z Node Set",
        "x",
        "0.0",
    ));
    text.push_str(&prescribed(
        "Fix Bottom Rigid Body Motion In Z",
        "Bottom Line Along X Node Set",
        "z",
        "0.0",
    ));
    text.push_str(&prescribed(
        "Fix Top Rigid Body Motion In X",
        "Top Line Along Z Node Set",
        "x",
        "0.0",
    ));
    text.push_str(&prescribed(
        "Fix Top Rigid Body Motion In Z",
        "Top Line Along X Node Set",
        "z",
        "0.0",
    ));
    text.push_str(&solver_section(names.points));
    text.push_str(
        "  # The strain gauge: the points nearest (0, ±1.27, 0) cm, 1 inch apart; the load cells: the
  # grip reactions.
  Compute Class Parameters:
",
    );
    text.push_str(&compute_classes(names.gauge));
    text.push_str(&output_section(name));
    text
}

/// Above this many points the deck solves Jacobian-free: the correspondence tangent couples
/// two-hop neighbours (about 12 GB for its blocks and CSR at 99,000 points, `peridyn check`),
/// while the direct solve is the fastest choice for small specimens (40 s at 5,000 points).
pub const JACOBIAN_FREE_ABOVE_POINTS: usize = 20_000;

/// `Solver`: 4 load steps; Newton with the direct solve of the assembled tangent up to
/// [`JACOBIAN_FREE_ABOVE_POINTS`], Jacobian-free Newton–Krylov preconditioned by AMG on the
/// one-hop operator beyond (no tangent assembled; the linear tolerance 1e-4 is an inexact
/// Newton step: Newton still converges to the absolute tolerance, in one more iteration at
/// most, with far fewer Krylov iterations than 1e-7).
fn solver_section(points: usize) -> String {
    if points <= JACOBIAN_FREE_ABOVE_POINTS {
        return "  Solver:
    Verbose: false
    Initial Time: 0.0
    Final Time: 1.0
    QuasiStatic:
      Number of Load Steps: 4
      Absolute Tolerance: 1.0
      Maximum Solver Iterations: 10
"
        .to_string();
    }
    "  # Jacobian-free Newton–Krylov with algebraic multigrid (peridyn's `AMG`): the assembled
  # two-hop tangent of this many points would not fit in memory.
  Solver:
    Verbose: true
    Initial Time: 0.0
    Final Time: 1.0
    Peridigm Preconditioner: \"AMG\"
    Linear Solver Tolerance: 1.0e-4
    NOXQuasiStatic:
      Number of Load Steps: 4
      Max Solver Iterations: 20
      Absolute Tolerance: 1.0
      Direction:
        Method: \"Newton\"
        Newton:
          Linear Solver:
            Jacobian Operator: \"Matrix-Free\"
            Preconditioner: \"User Defined\"
"
    .to_string()
}

/// The gauge (`Nearest_Point_Data` at the upper and lower gauge points) and the load cells
/// (`Block_Data` sums of `Force` over the grips), with the labels `peridyn modulus` reads.
fn compute_classes(gauge: [[f64; 3]; 2]) -> String {
    let [top, bottom] = gauge;
    let mut text = String::new();
    text.push_str(&nearest_point(
        "Strain Gage Top Initial Position",
        top,
        "Model_Coordinates",
        "Gage_Top_Initial_Position",
    ));
    text.push_str(&nearest_point(
        "Strain Gage Bottom Initial Position",
        bottom,
        "Model_Coordinates",
        "Gage_Bottom_Initial_Position",
    ));
    text.push_str(&nearest_point(
        "Strain Gage Top Displacement",
        top,
        "Displacement",
        "Gage_Top_Displacement",
    ));
    text.push_str(&nearest_point(
        "Strain Gage Bottom Displacement",
        bottom,
        "Displacement",
        "Gage_Bottom_Displacement",
    ));
    for (title, block, label) in [
        ("Top Reaction Force", "block_3", "Top_Reaction_Force"),
        ("Bottom Reaction Force", "block_1", "Bottom_Reaction_Force"),
    ] {
        text.push_str(&format!(
            "    {title}:\n      Compute Class: \"Block_Data\"\n      Calculation Type: \"Sum\"\n      Block: \"{block}\"\n      Variable: \"Force\"\n      Output Label: \"{label}\"\n"
        ));
    }
    text
}

/// The Exodus output with the globals the CSV carries.
fn output_section(name: &str) -> String {
    format!(
        "  Output:
    Output File Type: \"ExodusII\"
    Output Filename: \"{name}\"
    Output Frequency: 1
    Output Variables:
      Displacement: true
      Force: true
      Volume: true
      Cauchy_Stress: true
      Gage_Top_Initial_Position: true
      Gage_Bottom_Initial_Position: true
      Gage_Top_Displacement: true
      Gage_Bottom_Displacement: true
      Top_Reaction_Force: true
      Bottom_Reaction_Force: true
"
    )
}
