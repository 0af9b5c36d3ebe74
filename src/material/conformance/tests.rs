//! The conformance suite of the material registry: every model of [`MATERIALS`] is read from its
//! declared example through the deck, built by the set-up and checked, undamaged and with
//! broken bonds, for what every constitutive model owes the rest of the run:
//!
//! * its declaration: the example reads without warnings, every key it writes is declared and
//!   documented, the built material reports the declaration, thermal strain is taken or refused
//!   as declared;
//! * rigid motion gives zero force and energy (a translation, and a finite rotation, or for a
//!   small-displacement model a rotation small enough that its second-order force vanishes);
//! * the forces conserve linear and angular momentum, with the history evolving;
//! * the tangent (every method the model declares) matches central differences of the force;
//! * a rejected step leaves the committed history as it was and the retried step as a run
//!   that never tried it (commit and restore);
//! * the restart file's round trip gives back the history, and the next step equals the
//!   uninterrupted run's;
//! * on N ranks (when the model runs on ranks) the owned points' forces are bitwise the
//!   one-rank run's.
//!
//! The damage models' suite (`damage/conformance/tests.rs`) uses the same body and deck. A model
//! in the registry cannot skip it: the loops run over the registry.

use std::sync::Arc;

use crate::damage::DamageEntry;
use crate::history::History;
use crate::io::deck::{parse_str, Deck, DeckFormat};
use crate::material::{Material, MaterialEntry, MATERIALS};
use crate::model::test_support::{lattice, Rng};
use crate::model::{FieldCarrier, Model, ModelDeclaration};
use crate::parallel::{check_distributable, halo_depth, outer_ghosts_need_physics, Subdomain};
use crate::physics::{Configuration, Physics};
use crate::state::State;
use crate::tangent::{BlockTangent, TangentMethod};

/// Points per edge of the body's lattice (spacing 1).
const EDGE: usize = 6;
/// The block's horizon (the models' examples are written for it).
pub(crate) const HORIZON: f64 = 1.8;
/// Δt of a step, for the models whose response depends on time.
const STEP: f64 = 0.1;

/// The points of the conformance body: a 6³ lattice of spacing 1 with every point moved by up
/// to ±0.1 in each direction and volumes 0.8–1.2, so that families and volumes are irregular;
/// `x y z block volume` lines of a `Text File` discretization.
fn points_file() -> String {
    let mut rng = Rng::new(17);
    lattice(EDGE)
        .iter()
        .map(|p| {
            let [x, y, z] = p.map(|c| c + 0.2 * (rng.uniform() - 0.5));
            let volume = 0.8 + 0.4 * rng.uniform();
            format!("{x:.17e} {y:.17e} {z:.17e} 1 {volume:.17e}\n")
        })
        .collect()
}

/// `text` indented by `spaces`, line by line.
fn indented(text: &str, spaces: usize) -> String {
    text.lines()
        .map(|line| format!("{}{line}\n", " ".repeat(spaces)))
        .collect()
}

/// A deck of one block of `material` with the damage model `damage`, each written with its
/// declared example, on the conformance body (its points file written to `dir`).
pub(crate) fn deck(
    dir: &std::path::Path,
    material: &MaterialEntry,
    damage: Option<&DamageEntry>,
) -> Deck {
    std::fs::write(dir.join("points.txt"), points_file()).unwrap();
    let mut text = String::from(
        "Peridigm:\n  Discretization:\n    Type: \"Text File\"\n    Input Mesh File: \"points.txt\"\n  Materials:\n    M:\n",
    );
    text += &format!("      Material Model: \"{}\"\n", material.deck_name());
    text += &indented(material.declaration.example, 6);
    if let Some(damage) = damage {
        text += "  Damage Models:\n    D:\n";
        text += &format!("      Damage Model: \"{}\"\n", damage.deck_name());
        text += &indented(damage.declaration.example, 6);
    }
    text += "  Blocks:\n    B:\n      Block Names: \"block_1\"\n      Material: \"M\"\n";
    if damage.is_some() {
        text += "      Damage Model: \"D\"\n";
    }
    text += &format!("      Horizon: {HORIZON}\n");
    text += "  Solver:\n    Final Time: 1.0\n    Verlet:\n      Fixed dt: 0.1\n";
    parse_str(&text, DeckFormat::Yaml, &dir.join("deck.yaml"))
        .unwrap_or_else(|e| panic!("the example deck of {}: {e}\n{text}", material.deck_name()))
}

/// A body of the conformance deck: its model, physics and state (history allocated from the
/// declarations, committed copies kept, Δt = [`STEP`]).
pub(crate) struct Body {
    pub(crate) deck: Deck,
    pub(crate) model: Model,
    pub(crate) physics: Physics,
    pub(crate) state: State,
    /// Bond damage held fixed in every evaluation (the materials' damaged case), or `None`.
    pub(crate) fixed_damage: Option<Vec<f32>>,
}

impl Body {
    /// The body of `deck` (the whole model, one rank).
    pub(crate) fn new(deck: Deck) -> Self {
        let model = crate::setup::build(&deck).unwrap();
        Self::of(deck, model)
    }

    /// The body of `deck` on the points of `model` (the whole model or a rank's share).
    pub(crate) fn of(deck: Deck, model: Model) -> Self {
        let physics = crate::setup::build_physics(&deck, &model).unwrap();
        let state = initial_state(&model, &physics);
        Self {
            deck,
            model,
            physics,
            state,
            fixed_damage: None,
        }
    }

    /// The material of the body's block.
    pub(crate) fn material(&self) -> &dyn Material {
        &*self.physics.blocks[0].material
    }

    /// Breaks about a fifth of the pairs (both directions) and damages a tenth partly, held
    /// fixed from now on (`seed` picks them).
    pub(crate) fn break_some_bonds(&mut self, seed: u64) {
        self.fixed_damage = Some(broken_pairs(&self.model, seed));
    }

    /// Force density at `y`: the trial history advanced from the committed one, and the bond
    /// damage either held fixed or updated by the damage model (trial values, from the
    /// committed ones after a restore).
    pub(crate) fn force(&mut self, y: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let mut f = vec![[0.0; 3]; y.len()];
        let (bonds, points) = (&self.model.bonds, &self.model.points);
        match (&self.fixed_damage, &mut self.state.bond_damage) {
            (Some(fixed), _) => self.physics.internal_force_with_damage_fixed(
                bonds,
                points,
                y,
                Some(fixed),
                &mut self.state.history,
                &mut f,
            ),
            (None, Some(damage)) => {
                self.physics.internal_force(
                    bonds,
                    points,
                    y,
                    Some(damage.trial_mut()),
                    &mut self.state.history,
                    &mut f,
                );
            }
            (None, None) => self.physics.internal_force_with_damage_fixed(
                bonds,
                points,
                y,
                None,
                &mut self.state.history,
                &mut f,
            ),
        }
        f
    }

    /// Stored energy density of every point at `y` (from the history of the last force
    /// evaluation).
    pub(crate) fn energy(&self, y: &[[f64; 3]]) -> Vec<f64> {
        let mut w = vec![0.0; y.len()];
        self.physics.stored_energy_density(
            &self.model.bonds,
            &self.model.points,
            y,
            self.damage(),
            &self.state.history,
            &mut w,
        );
        w
    }

    /// Writes this body's committed state to a restart snapshot (one rank, every point) and
    /// applies it to `resumed`, a body of the same deck, as a restarted run does.
    pub(crate) fn restart_into(&self, resumed: &mut Body) {
        use crate::parallel::Serial;
        use crate::restart::{apply, capture, gather};
        let every: Vec<u32> = (0..self.model.points.len() as u32).collect();
        let snapshot = gather(&Serial, capture(&self.model, &every, None, &self.state)).unwrap();
        apply(&snapshot, &resumed.model, &every, None, &mut resumed.state).unwrap();
    }

    /// The bond damage the evaluations read.
    pub(crate) fn damage(&self) -> Option<&[f32]> {
        self.fixed_damage
            .as_deref()
            .or_else(|| self.state.bond_damage())
    }

    /// The reference positions moved by `u(X)`.
    pub(crate) fn moved(&self, mut u: impl FnMut([f64; 3]) -> [f64; 3]) -> Vec<[f64; 3]> {
        self.model
            .points
            .position
            .iter()
            .map(|&x| {
                let d = u(x);
                [x[0] + d[0], x[1] + d[1], x[2] + d[2]]
            })
            .collect()
    }

    /// A small stretch (1.002, 0.999, 1) with random displacements of up to ±`amplitude`/2
    /// (`seed` picks them): every term of a force is exercised.
    pub(crate) fn perturbed(&self, seed: u64, amplitude: f64) -> Vec<[f64; 3]> {
        let mut rng = Rng::new(seed);
        self.moved(|x| {
            let stretch = [0.002 * x[0], -0.001 * x[1], 0.0];
            stretch.map(|s| s + amplitude * (rng.uniform() - 0.5))
        })
    }

    /// Accepts the trial values of every staged field (a converged step).
    pub(crate) fn commit(&mut self) {
        self.state.commit();
    }
}

/// The state a run starts with (as the simulation's): at rest, bond damage when a block has a
/// damage model (initialised by it), the declared history with committed copies.
fn initial_state(model: &Model, physics: &Physics) -> State {
    let mut state = State::at_rest(&model.points.position, 0.0, false)
        .with_bond_damage(physics.has_bond_damage().then(|| model.bonds.num_bonds()));
    if let Some(bond_damage) = &mut state.bond_damage {
        physics.initialize_bond_damage(&model.bonds, &model.points, bond_damage.trial_mut());
    }
    state.history = History::allocate(
        physics
            .blocks
            .iter()
            .flat_map(|block| block.material.declaration().fields),
        model.points.len(),
        model.bonds.num_bonds(),
    );
    state.history.set_step_duration(STEP);
    state.keep_committed();
    state
}

/// Bond damage with about a fifth of the pairs broken (d = 1) and a tenth damaged partly
/// (d = 0.4), both directions alike.
fn broken_pairs(model: &Model, seed: u64) -> Vec<f32> {
    let mut rng = Rng::new(seed);
    let bonds = &model.bonds;
    let mut damage = vec![0.0f32; bonds.num_bonds()];
    for i in 0..bonds.num_points() {
        for b in bonds.range(i) {
            let j = bonds.neighbor[b] as usize;
            let u = rng.uniform();
            if j > i && u < 0.3 {
                let back = bonds.offsets[j] + bonds.family(j).binary_search(&(i as u32)).unwrap();
                let d = if u < 0.2 { 1.0 } else { 0.4 };
                damage[b] = d;
                damage[back] = d;
            }
        }
    }
    damage
}

/// |v|.
fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// The largest |F_i|.
pub(crate) fn largest(f: &[[f64; 3]]) -> f64 {
    f.iter().map(|&v| norm(v)).fold(0.0, f64::max)
}

/// Rotation by `angle` about the unit axis `a` (Rodrigues), applied to `x` about `center`.
fn rotated(x: [f64; 3], a: [f64; 3], angle: f64, center: [f64; 3]) -> [f64; 3] {
    let (s, c) = angle.sin_cos();
    let d = [0, 1, 2].map(|k| x[k] - center[k]);
    let dot = a[0] * d[0] + a[1] * d[1] + a[2] * d[2];
    let cross = [
        a[1] * d[2] - a[2] * d[1],
        a[2] * d[0] - a[0] * d[2],
        a[0] * d[1] - a[1] * d[0],
    ];
    [0, 1, 2].map(|k| center[k] + c * d[k] + s * cross[k] + (1.0 - c) * dot * a[k])
}

/// Rigid motions of the body: a translation and a rotation (about a skew axis through the
/// body's centre, then a translation) by `angle`.
pub(crate) fn rigid_motions(body: &Body, angle: f64) -> Vec<Vec<[f64; 3]>> {
    let n = 1.0 / 3f64.sqrt();
    let center = [2.5, 2.5, 2.5];
    vec![
        body.moved(|_| [3.0, -1.0, 0.5]),
        body.model
            .points
            .position
            .iter()
            .map(|&x| {
                let y = rotated(x, [n, n, n], angle, center);
                [y[0] + 10.0, y[1] - 5.0, y[2] + 2.0]
            })
            .collect(),
    ]
}

/// |Σ F_i V_i| and |Σ Y_i × F_i V_i| relative to Σ |F_i V_i| (1 + |Y_i|); for a
/// small-displacement model, whose pair forces act along the reference bonds, the moments
/// about the reference positions X_i.
pub(crate) fn momentum_defects(body: &Body, y: &[[f64; 3]], f: &[[f64; 3]]) -> (f64, f64) {
    let arms = if body.material().declaration().small_displacement {
        &body.model.points.position
    } else {
        y
    };
    let mut linear = [0.0; 3];
    let mut angular = [0.0; 3];
    let mut magnitude = 0.0;
    for ((fi, yi), &vi) in f.iter().zip(arms).zip(&body.model.points.volume) {
        let p = fi.map(|c| c * vi);
        for k in 0..3 {
            linear[k] += p[k];
        }
        angular[0] += yi[1] * p[2] - yi[2] * p[1];
        angular[1] += yi[2] * p[0] - yi[0] * p[2];
        angular[2] += yi[0] * p[1] - yi[1] * p[0];
        magnitude += norm(p) * (1.0 + norm(*yi));
    }
    assert!(magnitude > 0.0, "the configuration must carry force");
    (norm(linear) / magnitude, norm(angular) / magnitude)
}

/// The number of points whose staged history changed in the last force evaluation: a point
/// field's entry, or a bond field's entry in the point's row.
pub(crate) fn evolved_points(body: &Body) -> usize {
    let bonds = &body.model.bonds;
    let n = body.model.points.len();
    let mut changed = vec![false; n];
    for (declaration, values) in body.state.history.fields() {
        let (trial, committed) = (values.trial(), values.committed());
        let per = trial.len()
            / match declaration.carrier {
                FieldCarrier::Point => n,
                FieldCarrier::Bond => bonds.num_bonds(),
            };
        for (p, flag) in changed.iter_mut().enumerate() {
            let range = match declaration.carrier {
                FieldCarrier::Point => per * p..per * (p + 1),
                FieldCarrier::Bond => per * bonds.offsets[p]..per * bonds.offsets[p + 1],
            };
            *flag |= trial[range.clone()] != committed[range];
        }
    }
    changed.iter().filter(|&&c| c).count()
}

/// max |J − J_FD| / max |J_FD| of the body's tangent by `method` at `y` over a few columns
/// (interior and surface points), J_FD from central differences of the force itself (each
/// probe advancing the trial history from the same committed one).
pub(crate) fn tangent_error(body: &mut Body, y: &[[f64; 3]], method: TangentMethod) -> f64 {
    let pattern = Arc::new(body.physics.tangent_pattern(&body.model.bonds));
    let mut tangent = BlockTangent::zeros(pattern);
    let damage = body.damage().map(<[f32]>::to_vec);
    body.physics
        .tangent_with(
            &body.model.bonds,
            &body.model.points,
            Configuration {
                position: y,
                bond_damage: damage.as_deref(),
                history: &body.state.history,
            },
            method,
            &mut tangent,
        )
        .unwrap();
    let h = 1e-6;
    let (mut largest, mut worst) = (0.0f64, 0.0f64);
    let n = y.len();
    for j in [0, 43, 100, n / 2, n - 1] {
        for l in 0..3 {
            let mut plus = y.to_vec();
            plus[j][l] += h;
            let mut minus = y.to_vec();
            minus[j][l] -= h;
            let (fp, fm) = (body.force(&plus), body.force(&minus));
            for i in 0..n {
                for k in 0..3 {
                    let fd = body.model.points.volume[i] * (fp[i][k] - fm[i][k]) / (2.0 * h);
                    let exact = tangent.block(i, j).map_or(0.0, |b| b[k][l]);
                    largest = largest.max(fd.abs());
                    worst = worst.max((exact - fd).abs());
                }
            }
        }
    }
    assert!(largest > 0.0);
    worst / largest
}

/// The body's bond damage as a rank's share of it: the entries of the share's bonds.
fn share_of_damage(global: &Model, damage: &[f32], sub: &Subdomain) -> Vec<f32> {
    let local = &sub.model.bonds;
    let to_global = sub.plan.global();
    let mut share = vec![0.0f32; local.num_bonds()];
    for l in 0..local.num_points() {
        let g = to_global[l] as usize;
        for b in local.range(l) {
            let j = to_global[local.neighbor[b] as usize];
            let k = global.bonds.family(g).binary_search(&j).unwrap();
            share[b] = damage[global.bonds.offsets[g] + k];
        }
    }
    share
}

/// The forces at `y` of every owned point of `ranks` ranks (each rank's share built from the
/// body's deck and global model, its ghosts at their places in `y`, the fixed damage of the
/// body taken over), gathered in global order; `None` when the deck does not run on ranks.
pub(crate) fn forces_on_ranks(body: &Body, ranks: usize, y: &[[f64; 3]]) -> Option<Vec<[f64; 3]>> {
    check_distributable(&body.deck, ranks).ok()?;
    let (depth, outer) = (
        halo_depth(&body.deck),
        outer_ghosts_need_physics(&body.deck),
    );
    let mut gathered = vec![[f64::NAN; 3]; y.len()];
    for rank in 0..ranks {
        let sub = Subdomain::new(&body.model, ranks, rank, depth, outer);
        let ghost = sub.ghost_mask();
        let to_global = sub.plan.global().to_vec();
        let mut share = Body::of(body.deck.clone(), sub.model.clone());
        share.physics.restrict_forces(&|p| !ghost[p as usize]);
        share.fixed_damage = body
            .fixed_damage
            .as_ref()
            .map(|d| share_of_damage(&body.model, d, &sub));
        let local: Vec<[f64; 3]> = to_global.iter().map(|&g| y[g as usize]).collect();
        let f = share.force(&local);
        for &l in sub.owned() {
            gathered[to_global[l as usize] as usize] = f[l as usize];
        }
    }
    Some(gathered)
}

/// Every key `declaration` lists is documented (meaning, unit, default), and every key its
/// example writes is one it declares (`name` for messages).
pub(crate) fn assert_keys_documented_and_declared(name: &str, declaration: &ModelDeclaration) {
    for doc in declaration.deck_keys {
        assert!(
            !doc.meaning.is_empty() && !doc.unit.is_empty() && !doc.default.is_empty(),
            "{name}: key {} is not documented",
            doc.key
        );
    }
    for line in declaration.example.lines().filter(|l| !l.starts_with(' ')) {
        let key = line.split(':').next().unwrap();
        assert!(
            declaration.key(key).is_some(),
            "{name}: {key} is not declared"
        );
    }
}

/// Every material of the registry, with its name for messages.
fn materials() -> impl Iterator<Item = (&'static str, &'static MaterialEntry)> {
    MATERIALS.iter().map(|entry| (entry.deck_name(), entry))
}

/// The body of `entry` (undamaged, or with broken bonds when `damaged`).
fn body_of(dir: &std::path::Path, entry: &MaterialEntry, damaged: bool) -> Body {
    let mut body = Body::new(deck(dir, entry, None));
    if damaged {
        body.break_some_bonds(4);
    }
    body
}

#[test]
fn every_material_reads_its_example_and_reports_its_declaration() {
    let dir = tempfile::tempdir().unwrap();
    for (name, entry) in materials() {
        let declaration = entry.declaration;
        assert_keys_documented_and_declared(name, declaration);
        let deck = deck(dir.path(), entry, None);
        assert!(deck.warnings.is_empty(), "{name}: {:?}", deck.warnings);
        assert!(std::ptr::eq(deck.materials[0].model, entry), "{name}");
        let body = Body::new(deck);
        assert_eq!(body.material().declaration(), declaration, "{name}");
        assert_eq!(body.material().model_name(), name);
    }
}

#[test]
fn thermal_strain_is_taken_exactly_by_the_models_that_declare_it() {
    let dir = tempfile::tempdir().unwrap();
    for (name, entry) in materials() {
        let mut body = Body::new(deck(dir.path(), entry, None));
        let material = &mut body.physics.blocks[0].material;
        let taken = material.set_thermal_expansion(1e-5);
        assert_eq!(taken.is_ok(), entry.declaration.thermal_strain, "{name}");
        if entry.declaration.thermal_strain {
            assert_eq!(material.thermal_expansion(), Some(1e-5), "{name}");
            assert!(material.set_thermal_expansion(f64::NAN).is_err(), "{name}");
        } else {
            let error = taken.unwrap_err().to_string();
            assert!(
                error.contains("Thermal Expansion Coefficient") && error.contains(name),
                "{name}: {error}"
            );
        }
    }
}

#[test]
fn rigid_motion_gives_zero_force_and_energy_undamaged_and_damaged() {
    // Every bond keeps its length, so no model strains: the force left is round-off,
    // compared with the force of a 1e-3 random displacement. A small-displacement model is
    // force free only to second order in the rotation: 1e-6 rad leaves extensions of order
    // ζθ²/2 = 5e-13 against the 1e-3 of the scale (its own checks show the second order).
    let dir = tempfile::tempdir().unwrap();
    for (name, entry) in materials() {
        for damaged in [false, true] {
            let mut body = body_of(dir.path(), entry, damaged);
            let strained = body.perturbed(1, 2e-3);
            let scale = largest(&body.force(&strained));
            assert!(scale > 0.0, "{name}");
            body.state.restore();
            let angle = if entry.declaration.small_displacement {
                1e-6
            } else {
                0.6
            };
            for y in rigid_motions(&body, angle) {
                let f = body.force(&y);
                assert!(
                    largest(&f) <= 1e-9 * scale,
                    "{name} (damaged: {damaged}): {} vs {scale}",
                    largest(&f)
                );
                let w = body.energy(&y);
                assert!(
                    w.iter().all(|w| w.abs() <= 1e-18 * scale),
                    "{name} (damaged: {damaged}): energy {:?}",
                    w.iter().fold(0.0f64, |m, w| m.max(w.abs()))
                );
                // No bond field (plastic extension, permanent stretch, back extension) moves.
                for (declaration, values) in body.state.history.fields() {
                    if declaration.carrier == FieldCarrier::Bond {
                        assert!(
                            values.trial().iter().all(|&v| v.abs() < 1e-14),
                            "{name}: {} moved",
                            declaration.name
                        );
                    }
                }
                body.state.restore();
            }
        }
    }
}

#[test]
fn the_forces_conserve_linear_and_angular_momentum_while_the_history_evolves() {
    let dir = tempfile::tempdir().unwrap();
    for (name, entry) in materials() {
        for damaged in [false, true] {
            let mut body = body_of(dir.path(), entry, damaged);
            let y = body.perturbed(2, 0.05);
            let f = body.force(&y);
            if !entry.declaration.fields.iter().all(|f| !f.staged) {
                let evolved = evolved_points(&body);
                assert!(
                    evolved > body.model.points.len() / 4,
                    "{name}: the history of only {evolved} points evolves"
                );
            }
            let (linear, angular) = momentum_defects(&body, &y, &f);
            assert!(
                linear < 1e-13,
                "{name} (damaged: {damaged}): linear {linear}"
            );
            assert!(
                angular < 1e-13,
                "{name} (damaged: {damaged}): angular {angular}"
            );
        }
    }
}

#[test]
fn every_declared_tangent_matches_central_differences_undamaged_and_damaged() {
    // From a committed step (0.02 displacements) to a trial state away from it (0.05), in
    // which the plastic models yield at most points.
    let dir = tempfile::tempdir().unwrap();
    for (name, entry) in materials() {
        let methods: &[TangentMethod] = match entry.declaration.tangent {
            crate::model::TangentSupport::None => &[],
            crate::model::TangentSupport::Differentiated => {
                &[TangentMethod::AutomaticDifferentiation]
            }
            crate::model::TangentSupport::Analytic => &[
                TangentMethod::Analytic,
                TangentMethod::AutomaticDifferentiation,
            ],
        };
        for damaged in [false, true] {
            let mut body = body_of(dir.path(), entry, damaged);
            let start = body.perturbed(2, 0.02);
            body.force(&start);
            body.commit();
            let y = body.perturbed(9, 0.05);
            for &method in methods {
                let error = tangent_error(&mut body, &y, method);
                assert!(
                    error < 1e-6,
                    "{name} (damaged: {damaged}), {method:?}: relative error {error}"
                );
            }
        }
    }
}

#[test]
fn a_rejected_step_leaves_the_committed_history_and_the_retried_step_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    for (name, entry) in materials() {
        for damaged in [false, true] {
            let mut body = body_of(dir.path(), entry, damaged);
            let mut twin = body_of(dir.path(), entry, damaged);
            let start = body.perturbed(3, 0.02);
            for b in [&mut body, &mut twin] {
                b.force(&start);
                b.commit();
            }
            let committed = body.state.history.clone();
            // A trial step further away, then rejected.
            body.force(&body.perturbed(5, 0.08));
            body.state.restore();
            assert_eq!(body.state.history, committed, "{name}");
            // The retried step is exactly that of a run that never tried the rejected one.
            let y = body.perturbed(6, 0.05);
            assert_eq!(
                body.force(&y),
                twin.force(&y),
                "{name} (damaged: {damaged})"
            );
            assert_eq!(body.state.history, twin.state.history, "{name}");
        }
    }
}

#[test]
fn the_restart_round_trip_gives_back_the_history_and_the_next_step() {
    let dir = tempfile::tempdir().unwrap();
    for (name, entry) in materials() {
        let mut body = body_of(dir.path(), entry, false);
        let start = body.perturbed(7, 0.05);
        body.force(&start);
        body.commit();
        let mut resumed = body_of(dir.path(), entry, false);
        body.restart_into(&mut resumed);
        assert_eq!(resumed.state.history, body.state.history, "{name}");
        let y = body.perturbed(8, 0.05);
        assert_eq!(resumed.force(&y), body.force(&y), "{name}");
        assert_eq!(resumed.state.history, body.state.history, "{name}");
    }
}

#[test]
fn on_ranks_the_owned_forces_are_those_of_one_rank_bitwise() {
    let dir = tempfile::tempdir().unwrap();
    let mut ran = 0;
    for (name, entry) in materials() {
        for damaged in [false, true] {
            let mut body = body_of(dir.path(), entry, damaged);
            let y = body.perturbed(10, 0.05);
            let one = body.force(&y);
            for ranks in [2, 3] {
                let Some(many) = forces_on_ranks(&body, ranks, &y) else {
                    continue;
                };
                ran += 1;
                assert!(one == many, "{name} (damaged: {damaged}) on {ranks} ranks");
            }
        }
    }
    assert!(ran > 0, "no model runs on ranks");
}
