//! Pre-cracks: the `Initial Damage` damage model and the `Exodus Mesh` bond filter.
//!
//! Every deck here is one layer of a square lattice (spacing 1, `Text File` points at integer
//! x = 0…NX−1, y = 0…NY−1, z = 0, volume 1) with horizon δ = 2.5, cracked by a plane y = 4.5
//! between rows 4 and 5.
//!
//! # How many bonds cross the crack (closed form)
//!
//! A `Text File` family holds every point with |ξ|² ≤ δ² = 6.25, so the bonds are the integer
//! offsets (dx, dy) ≠ 0 with dx² + dy² ≤ 6.25: for dy = 0, dx = ±1, ±2 (4); for |dy| = 1,
//! |dx| ≤ 2 (5 each); for |dy| = 2, |dx| ≤ 1 (3 each). An interior point has 4 + 2·5 + 2·3 = 20
//! bonds.
//!
//! A bond with vertical offset dy ≥ 1 crosses y = 4.5 when its lower point lies in one of the
//! dy rows 5 − dy … 4 (all inside the plate for NY = 10), and its horizontal offset dx leaves
//! NX − |dx| positions for the pair inside a row of NX points. A crack across the whole plate
//! (x from −1 to NX) therefore cuts
//!
//! ```text
//! U = Σ_{dy=1,2} Σ_{dx} dy·(NX − |dx|) = 1·(5·NX − 6) + 2·(3·NX − 2) = 11·NX − 10
//! ```
//!
//! pairs, 2U directed bonds: 122 pairs, 244 directed bonds for NX = 12.
//!
//! Point damage of an interior point (|x| ≥ 2 from the sides): in row 4 every bond going up
//! crosses (5 + 3 = 8 of 20: 0.4); in row 3 only those with dy = 2 (3 of 20: 0.15); rows 5 and
//! 6 likewise by symmetry; other rows 0.

use peridyn::io::deck;
use peridyn::io::exodus::{write_shell_mesh, ExodusFile};
use peridyn::model::Model;
use peridyn::setup;
use std::path::Path;

const NX: usize = 12;
const NY: usize = 10;

/// Pairs (undirected bonds) crossing y = 4.5 across the whole plate: 11·NX − 10 (module doc).
fn crossing_pairs(nx: usize) -> usize {
    11 * nx - 10
}

/// The lattice mesh, one line per point, x fastest (line k is point (k % NX, k / NX)).
fn lattice_mesh() -> String {
    let mut lines = Vec::new();
    for y in 0..NY {
        for x in 0..NX {
            lines.push(format!("{x}.0 {y}.0 0.0 1 1.0"));
        }
    }
    lines.join("\n") + "\n"
}

/// 1-based node ids of the rows `rows`.
fn row_ids(rows: std::ops::Range<usize>) -> String {
    rows.flat_map(|y| (0..NX).map(move |x| (y * NX + x + 1).to_string()))
        .collect::<Vec<_>>()
        .join(" ")
}

/// A rectangle in the plane y = 4.5 from x = `x0` to `x1` (bottom edge along +x) and z from
/// −1 to 1 (side = bottom × normal = (1,0,0) × (0,1,0) = +z, from the corner at z = −1).
fn rectangle(name: &str, x0: f64, x1: f64, indent: &str) -> String {
    format!(
        "{indent}{name}:\n\
         {indent}  Type: \"Rectangular_Plane\"\n\
         {indent}  Normal_X: 0.0\n{indent}  Normal_Y: 1.0\n{indent}  Normal_Z: 0.0\n\
         {indent}  Lower_Left_Corner_X: {x0:?}\n{indent}  Lower_Left_Corner_Y: 4.5\n{indent}  Lower_Left_Corner_Z: -1.0\n\
         {indent}  Bottom_Unit_Vector_X: 1.0\n{indent}  Bottom_Unit_Vector_Y: 0.0\n{indent}  Bottom_Unit_Vector_Z: 0.0\n\
         {indent}  Bottom_Length: {:?}\n{indent}  Side_Length: 2.0\n",
        x1 - x0
    )
}

fn shell(name: &str, file: &str, indent: &str) -> String {
    format!("{indent}{name}:\n{indent}  Type: \"Exodus Mesh\"\n{indent}  File Name: \"{file}\"\n")
}

/// A deck on the lattice: `filters` under `Discretization → Bond Filters` (8-space indented
/// entries, or empty), `damage` as the `Damage Models` list (or empty), and a Verlet solver of
/// `steps` steps of Δt = 0.5 with the rows above the crack moving up at 0.01 and those below
/// moving down, from an initial velocity.
fn deck_text(filters: &str, damage: &str, steps: usize) -> String {
    let filters = if filters.is_empty() {
        String::new()
    } else {
        format!("    Bond Filters:\n{filters}")
    };
    let damage_model = if damage.is_empty() {
        ""
    } else {
        "      Damage Model: \"Crack\"\n"
    };
    format!(
        r#"Peridigm:
  Discretization:
    Type: "Text File"
    Input Mesh File: "mesh.txt"
{filters}  Materials:
    Plate:
      Material Model: "Elastic Bond Based"
      Density: 1.0
      Bulk Modulus: 1.0
{damage}  Blocks:
    All:
      Block Names: "block_1"
      Material: "Plate"
{damage_model}      Horizon: 2.5
  Boundary Conditions:
    Top Node Set: "{top}"
    Bottom Node Set: "{bottom}"
    Up:
      Type: "Initial Velocity"
      Node Set: "Top Node Set"
      Coordinate: "y"
      Value: "0.01"
    Down:
      Type: "Initial Velocity"
      Node Set: "Bottom Node Set"
      Coordinate: "y"
      Value: "-0.01"
  Solver:
    Initial Time: 0.0
    Final Time: {final_time:?}
    Verlet:
      Fixed dt: 0.5
  Output:
    Output Filename: "plate"
    Output Frequency: {steps}
    Output Variables:
      Displacement: true
      Damage: true
"#,
        top = row_ids(5..NY),
        bottom = row_ids(0..5),
        final_time = 0.5 * steps as f64,
    )
}

fn initial_damage(filters: &str) -> String {
    format!(
        "  Damage Models:\n    Crack:\n      Damage Model: \"Initial Damage\"\n      Bond Filters:\n{filters}"
    )
}

struct Plate {
    dir: tempfile::TempDir,
    deck: deck::Deck,
    model: Model,
}

impl Plate {
    fn new(deck_text: &str) -> Self {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("mesh.txt"), lattice_mesh()).unwrap();
        let path = dir.path().join("plate.yaml");
        std::fs::write(&path, deck_text).unwrap();
        let deck = deck::load(&path).unwrap_or_else(|e| panic!("{e}"));
        let model = setup::build(&deck).unwrap_or_else(|e| panic!("{e}"));
        Self { dir, deck, model }
    }

    /// Every directed bond as (mesh line of i, mesh line of j), sorted.
    fn bonds(&self) -> Vec<(u32, u32)> {
        let m = &self.model;
        let mut list: Vec<(u32, u32)> = (0..m.points.len())
            .flat_map(|i| {
                m.bonds
                    .family(i)
                    .iter()
                    .map(move |&j| (m.points.original_id[i], m.points.original_id[j as usize]))
            })
            .collect();
        list.sort_unstable();
        list
    }

    /// The initial bond damage of the damage models (all bonds, run order).
    fn initial_bond_damage(&self) -> Vec<f32> {
        let physics = setup::build_physics(&self.deck, &self.model).unwrap();
        let mut damage = vec![0.0f32; self.model.bonds.num_bonds()];
        physics.initialize_bond_damage(&self.model.bonds, &self.model.points, &mut damage);
        damage
    }

    /// Runs the deck and returns (Damage at the first frame, y-displacement at the last), in
    /// mesh order.
    fn run(&self) -> (Vec<f64>, Vec<f64>) {
        peridyn::simulation::run(&self.deck, &self.model, self.dir.path())
            .unwrap_or_else(|e| panic!("{e}"));
        let file = ExodusFile::open(&self.dir.path().join("plate.e")).unwrap();
        let damage = file.element_variable_index("Damage").unwrap();
        let uy = file.nodal_variable_index("DisplacementY").unwrap();
        let last = file.times.len() - 1;
        (
            file.element_values(0, damage, 0).unwrap().unwrap(),
            file.nodal_values(last, uy).unwrap(),
        )
    }
}

fn point(x: usize, y: usize) -> usize {
    y * NX + x
}

#[test]
fn initial_damage_breaks_exactly_the_bonds_across_the_plane_and_keeps_them() {
    let filter = rectangle("Plane", -1.0, NX as f64, "        ");
    let cracked = Plate::new(&deck_text("", &initial_damage(&filter), 1));
    let intact = Plate::new(&deck_text("", "", 1));
    // The bonds stay in the families.
    assert_eq!(cracked.bonds(), intact.bonds());
    let d = cracked.initial_bond_damage();
    let m = &cracked.model;
    let mut broken = 0;
    for i in 0..m.points.len() {
        for b in m.bonds.range(i) {
            let j = m.bonds.neighbor[b] as usize;
            let (yi, yj) = (m.points.position[i][1], m.points.position[j][1]);
            let crosses = yi.min(yj) < 4.5 && yi.max(yj) > 4.5;
            assert_eq!(d[b] == 1.0, crosses, "bond {i}→{j}");
            assert!(d[b] == 0.0 || d[b] == 1.0);
            broken += usize::from(d[b] == 1.0);
        }
    }
    // 2·(11·NX − 10) directed bonds (module doc): 244 for NX = 12.
    assert_eq!(broken, 2 * crossing_pairs(NX));
    assert_eq!(broken, 244);
}

#[test]
fn point_damage_of_the_precrack_matches_the_lattice_fractions_and_the_crack_opens() {
    let filter = rectangle("Plane", -1.0, NX as f64, "        ");
    let steps = 200;
    let cracked = Plate::new(&deck_text("", &initial_damage(&filter), steps));
    let (damage, uy) = cracked.run();
    // Interior columns (2 ≤ x ≤ NX − 3): 8/20 next to the crack, 3/20 one row further, 0
    // beyond (module doc).
    for x in 2..NX - 2 {
        for (y, expected) in [(2, 0.0), (3, 0.15), (4, 0.4), (5, 0.4), (6, 0.15), (7, 0.0)] {
            let got = damage[point(x, y)];
            assert!((got - expected).abs() < 1e-15, "({x}, {y}): {got}");
        }
    }
    // No bond joins the two halves, and inside each half every point starts with the same
    // velocity: the halves translate rigidly, u_y = ±0.01·t exactly up to rounding.
    let t = 0.5 * steps as f64;
    for y in 0..NY {
        let expected = if y >= 5 { 0.01 * t } else { -0.01 * t };
        for x in 0..NX {
            let got = uy[point(x, y)];
            assert!((got - expected).abs() < 1e-9, "({x}, {y}): {got}");
        }
    }

    // The same plate without the crack holds together: the bonds across y = 4.5 stop the
    // halves. A bar whose halves start at ±v carries strain v/c behind the waves leaving its
    // centre (σ = ρcv, one-dimensional impact), c = √(E/ρ) ≈ 1.2 here (PMB: E = 3K(1 − 2ν),
    // ν = ¼), so two rows 1 apart open by about v/c ≈ 0.01 and the waves only reflect: the
    // opening stays of that order, against 0.02·t = 2 for the cracked plate. The bound 0.2
    // leaves a factor 20 for the discrete lattice and the free sides.
    let intact = Plate::new(&deck_text("", "", steps));
    let (damage, uy) = intact.run();
    assert!(damage.iter().all(|&d| d == 0.0));
    for x in 0..NX {
        let opening = uy[point(x, 5)] - uy[point(x, 4)];
        assert!(opening.abs() < 0.2, "column {x}: opening {opening}");
    }
}

#[test]
fn discretization_filter_removes_the_bonds_initial_damage_breaks() {
    let filter = rectangle("Plane", -1.0, NX as f64, "      ");
    let filtered = Plate::new(&deck_text(&filter, "", 1));
    let intact = Plate::new(&deck_text("", "", 1));
    assert_eq!(
        intact.bonds().len() - filtered.bonds().len(),
        2 * crossing_pairs(NX)
    );
}

/// Writes a planar quadrilateral shell mesh in the plane y = 4.5: the rectangle x ∈ [x0, x1],
/// z ∈ [−1, 1], cut into quads at the x positions `cuts` (strictly between x0 and x1) and at
/// z = 0.
fn write_planar_quads(path: &Path, x0: f64, x1: f64, cuts: &[f64]) {
    let xs: Vec<f64> = std::iter::once(x0)
        .chain(cuts.iter().copied())
        .chain(std::iter::once(x1))
        .collect();
    let zs = [-1.0, 0.0, 1.0];
    let mut coordinates = Vec::new();
    for &z in &zs {
        for &x in &xs {
            coordinates.push([x, 4.5, z]);
        }
    }
    let node = |ix: usize, iz: usize| (iz * xs.len() + ix) as u32;
    let mut connectivity = Vec::new();
    for iz in 0..zs.len() - 1 {
        for ix in 0..xs.len() - 1 {
            connectivity.extend([
                node(ix, iz),
                node(ix + 1, iz),
                node(ix + 1, iz + 1),
                node(ix, iz + 1),
            ]);
        }
    }
    write_shell_mesh(path, &coordinates, "SHELL4", 4, &connectivity).unwrap();
}

#[test]
fn exodus_mesh_filter_removes_the_bonds_of_the_equivalent_rectangle() {
    // Bonds cross y = 4.5 at x = x_i + dx/(2dy)·(2·(4.5 − y_i)): multiples of 0.25. The quads'
    // inner edges at x = 2.0, 5.5 and 8.25 lie exactly where bonds cross them (shared edges
    // between two faces, and between the two triangles of a quad along its diagonal), and z = 0
    // (the plane of the points) is a shared edge too: every crossing of a shared edge must be
    // cut. The partial crack ends at x = 5.5, where bonds also cross: the closed rectangle and
    // the closed triangles both cut them.
    for (x0, x1, cuts) in [
        (-1.0, NX as f64, &[2.0, 5.5, 8.25][..]),
        (-1.0, 5.5, &[2.0][..]),
    ] {
        let rectangle_deck = deck_text(&rectangle("Plane", x0, x1, "      "), "", 1);
        let by_rectangle = Plate::new(&rectangle_deck);
        let shell_deck = deck_text(&shell("Surface", "crack.g", "      "), "", 1);
        let dir = tempfile::tempdir().unwrap();
        write_planar_quads(&dir.path().join("crack.g"), x0, x1, cuts);
        std::fs::write(dir.path().join("mesh.txt"), lattice_mesh()).unwrap();
        let path = dir.path().join("plate.yaml");
        std::fs::write(&path, shell_deck).unwrap();
        let deck = deck::load(&path).unwrap_or_else(|e| panic!("{e}"));
        let model = setup::build(&deck).unwrap_or_else(|e| panic!("{e}"));
        let by_shell = Plate { dir, deck, model };
        assert_eq!(by_shell.bonds(), by_rectangle.bonds(), "crack to x = {x1}");
        let intact = Plate::new(&deck_text("", "", 1));
        let removed = intact.bonds().len() - by_shell.bonds().len();
        if x1 >= NX as f64 {
            assert_eq!(removed, 2 * crossing_pairs(NX));
        } else {
            assert!(removed > 0 && removed < 2 * crossing_pairs(NX), "{removed}");
        }
    }
}

#[test]
fn initial_damage_reads_an_exodus_mesh_too() {
    // The same through-crack as a shell mesh under Initial Damage: the same broken bonds.
    let dir = tempfile::tempdir().unwrap();
    write_planar_quads(&dir.path().join("crack.g"), -1.0, NX as f64, &[5.5]);
    std::fs::write(dir.path().join("mesh.txt"), lattice_mesh()).unwrap();
    let text = deck_text(
        "",
        &initial_damage(&shell("Surface", "crack.g", "        ")),
        1,
    );
    let path = dir.path().join("plate.yaml");
    std::fs::write(&path, text).unwrap();
    let deck = deck::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let model = setup::build(&deck).unwrap_or_else(|e| panic!("{e}"));
    let plate = Plate { dir, deck, model };
    let broken = plate
        .initial_bond_damage()
        .iter()
        .filter(|&&d| d == 1.0)
        .count();
    assert_eq!(broken, 2 * crossing_pairs(NX));
}

#[test]
fn a_missing_shell_mesh_names_the_key_and_the_file() {
    let text = deck_text(&shell("Surface", "nowhere.g", "      "), "", 1);
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("mesh.txt"), lattice_mesh()).unwrap();
    let path = dir.path().join("plate.yaml");
    std::fs::write(&path, text).unwrap();
    let deck = deck::load(&path).unwrap();
    let message = setup::build(&deck).unwrap_err().to_string();
    assert!(
        message.contains("Bond Filters → Surface → File Name") && message.contains("nowhere.g"),
        "{message}"
    );
}
