//! Short-range contact: pair law, pair selection (interactions, bonds), the skin rule and a
//! full Verlet rebound.
//!
//! Decks use Peridigm's `Text File` discretization (`x y z block volume`), so every point,
//! volume and block is chosen by the test.

use peridyn::contact::Contact;
use peridyn::io::deck;
use peridyn::model::Model;
use peridyn::physics::Physics;
use peridyn::setup;
use peridyn::solver::{VelocityVerlet, VerletSettings};
use peridyn::state::State;
use std::f64::consts::PI;

/// A deck with `mesh` as its text mesh, every block `block_1 … block_<blocks>` of one
/// bond-based material (ρ = 1) with horizon `horizon`, and `contact` as the `Contact` list
/// (indented by four spaces, or empty for none).
fn deck_text(blocks: usize, horizon: f64, omit_between_blocks: bool, contact: &str) -> String {
    let names: Vec<String> = (1..=blocks).map(|b| format!("block_{b}")).collect();
    format!(
        r#"Peridigm:
  Discretization:
    Type: "Text File"
    Input Mesh File: "mesh.txt"
    Omit Bonds Between Blocks: "{omit}"
  Materials:
    Soft:
      Material Model: "Elastic Bond Based"
      Density: 1.0
      Bulk Modulus: 1.0
  Blocks:
    All:
      Block Names: "{names}"
      Material: "Soft"
      Horizon: {horizon}
{contact}  Solver:
    Final Time: 1.0
    Verlet:
      Fixed dt: 1.0e-3
"#,
        omit = if omit_between_blocks { "All" } else { "None" },
        names = names.join(" "),
    )
}

/// Contact list with `Search Radius` `radius`, `Search Frequency` `frequency`, the given
/// models `(name, contact radius, spring constant, friction)` and interaction entries
/// (already formatted, 6-space indented).
fn contact_list(
    radius: f64,
    frequency: u64,
    models: &[(&str, f64, f64, f64)],
    interactions: &str,
) -> String {
    let mut text = format!(
        "  Contact:\n    Search Radius: {radius}\n    Search Frequency: {frequency}\n    Models:\n"
    );
    for (name, rc, k, mu) in models {
        text += &format!(
            "      {name}:\n        Contact Model: \"Short Range Force\"\n        Contact Radius: {rc}\n        Spring Constant: {k}\n        Friction Coefficient: {mu}\n"
        );
    }
    text += "    Interactions:\n";
    text += interactions;
    text
}

fn general(model: &str) -> String {
    format!("      General Contact:\n        Contact Model: \"{model}\"\n")
}

fn self_contact(model: &str) -> String {
    format!("      Self Contact:\n        Contact Model: \"{model}\"\n")
}

fn pair(name: &str, first: &str, second: &str, model: &str) -> String {
    format!(
        "      {name}:\n        First Block: \"{first}\"\n        Second Block: \"{second}\"\n        Contact Model: \"{model}\"\n"
    )
}

/// Points `(x, y, z, block id, volume)`.
type MeshPoint = (f64, f64, f64, u32, f64);

struct Setup {
    _dir: tempfile::TempDir,
    deck: deck::Deck,
    model: Model,
}

impl Setup {
    fn new(deck_text: &str, mesh: &[MeshPoint]) -> Self {
        let dir = tempfile::tempdir().unwrap();
        let lines: Vec<String> = mesh
            .iter()
            .map(|(x, y, z, b, v)| format!("{x} {y} {z} {b} {v}"))
            .collect();
        std::fs::write(dir.path().join("mesh.txt"), lines.join("\n")).unwrap();
        let path = dir.path().join("deck.yaml");
        std::fs::write(&path, deck_text).unwrap();
        let deck = deck::load(&path).unwrap_or_else(|e| panic!("{e}"));
        let model = setup::build(&deck).unwrap_or_else(|e| panic!("{e}"));
        Self {
            _dir: dir,
            deck,
            model,
        }
    }

    fn physics(&self) -> Physics {
        setup::build_physics(&self.deck, &self.model).unwrap_or_else(|e| panic!("{e}"))
    }

    fn contact(&self) -> Contact {
        Contact::from_deck(&self.deck, &self.model)
            .unwrap_or_else(|e| panic!("{e}"))
            .expect("deck has a Contact list")
    }

    /// Run index of the point with 0-based mesh line `k`.
    fn run(&self, k: usize) -> usize {
        self.model.run_index[k] as usize
    }

    /// Positions of all points in run order with point `k` (mesh order) moved to `to`.
    fn positions_with(&self, moves: &[(usize, [f64; 3])]) -> Vec<[f64; 3]> {
        let mut y = self.model.points.position.clone();
        for &(k, to) in moves {
            y[self.run(k)] = to;
        }
        y
    }
}

/// Force density on i from j by the documented law, with friction zero:
/// c_ij (r_c − r) V_j along −n, c_ij = 9 k/π (1/δ_i⁵ + 1/δ_j⁵) — Peridigm's
/// `9 k/(π δ⁴)·(r_c − r)/δ·V_j`, evaluated once from each point of the pair.
fn expected_magnitude(k: f64, rc: f64, r: f64, delta: f64, volume_j: f64) -> f64 {
    9.0 * k / PI * (2.0 / delta.powi(5)) * (rc - r) * volume_j
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * a.abs().max(b.abs()).max(1e-300)
}

#[test]
fn zero_beyond_radius_repulsive_inside_equal_and_opposite_and_not_between_bonded_points() {
    // A (block 1, V = 1) at 0; B (block 2, V = 2) 0.3 from A (inside r_c = 0.4, unbonded because
    // bonds between blocks are omitted); D (block 1) 0.2 from A: bonded to A (δ = 0.5) and
    // inside r_c, so excluded although Self Contact pairs block 1 with itself; D–B = 0.36 < r_c,
    // unbonded. C (block 2) 0.41 from A: just outside r_c.
    let (k, rc, delta) = (3.0, 0.4, 0.5);
    let contact = contact_list(
        1.0,
        1,
        &[("Model", rc, k, 0.0)],
        &(general("Model") + &self_contact("Model")),
    );
    let s = Setup::new(
        &deck_text(2, delta, true, &contact),
        &[
            (0.0, 0.0, 0.0, 1, 1.0),
            (0.3, 0.0, 0.0, 2, 2.0),
            (0.0, -0.2, 0.0, 1, 1.0),
            (-0.41, 0.0, 0.0, 2, 1.0),
        ],
    );
    let (a, b, d, c) = (s.run(0), s.run(1), s.run(2), s.run(3));
    let contact = s.contact();
    let mut contact_state = contact.initial_state();
    let y = s.model.points.position.clone();
    let v = vec![[0.0; 3]; y.len()];
    let f = contact
        .compute_force(&mut contact_state, &s.model, &y, &v)
        .to_vec();

    assert!(
        !contact.may_touch(&s.model, a, d),
        "bonded pair must be excluded"
    );
    assert!(contact.may_touch(&s.model, a, b));
    // A: only B acts, pushing A towards −x.
    let on_a = expected_magnitude(k, rc, 0.3, delta, 2.0);
    assert!(close(f[a][0], -on_a), "{:?} vs {on_a}", f[a]);
    assert_eq!([f[a][1], f[a][2]], [0.0, 0.0]);
    // C is 0.41 > r_c from A and farther from the others: no force.
    assert_eq!(f[c], [0.0; 3]);
    // D: only B (0.36 away) acts, along D − B.
    let r_db = (0.09f64 + 0.04).sqrt();
    let on_d = expected_magnitude(k, rc, r_db, delta, 2.0);
    let n_db = [-0.3 / r_db, -0.2 / r_db];
    assert!(close(f[d][0], on_d * n_db[0]) && close(f[d][1], on_d * n_db[1]));
    // Momentum: Σ V f = 0 (pairwise equal and opposite).
    let volume = &s.model.points.volume;
    let (total, scale) = f
        .iter()
        .zip(volume)
        .fold(([0.0; 3], [0.0; 3]), |(t, m), (f, v)| {
            (
                std::array::from_fn(|k| t[k] + v * f[k]),
                std::array::from_fn(|k| m[k] + (v * f[k]).abs()),
            )
        });
    for axis in 0..3 {
        assert!(
            total[axis].abs() <= 1e-14 * scale[axis].max(1.0),
            "axis {axis}: {total:?}"
        );
    }
    assert_eq!(contact_state.statistics().pairs_in_contact, 2);

    // Move B just outside r_c: nothing acts on A any more.
    let y = s.positions_with(&[(1, [0.4000001, 0.0, 0.0])]);
    let f = contact
        .compute_force(&mut contact_state, &s.model, &y, &v)
        .to_vec();
    assert_eq!(f[a], [0.0; 3]);
}

#[test]
fn friction_acts_against_sliding_with_peridigms_magnitude() {
    let (k, rc, delta, mu) = (3.0, 0.4, 0.5, 0.25);
    let contact = contact_list(1.0, 1, &[("Model", rc, k, mu)], &general("Model"));
    let s = Setup::new(
        &deck_text(2, delta, true, &contact),
        &[(0.0, 0.0, 0.0, 1, 1.0), (0.3, 0.0, 0.0, 2, 1.0)],
    );
    let (a, b) = (s.run(0), s.run(1));
    let y = s.model.points.position.clone();
    let mut v = vec![[0.0; 3]; 2];
    v[a] = [5.0, 2.0, 0.0]; // the normal part (x) must not matter
    v[b] = [0.0, -1.0, 0.0];
    let contact = s.contact();
    let mut contact_state = contact.initial_state();
    let f = contact
        .compute_force(&mut contact_state, &s.model, &y, &v)
        .to_vec();
    let normal = expected_magnitude(k, rc, 0.3, delta, 1.0);
    // Peridigm: friction μ |F_n| against the tangential velocity relative to the pair (+y for A).
    assert!(close(f[a][0], -normal));
    assert!(close(f[a][1], -mu * normal));
    assert!(close(f[b][1], mu * normal));
}

#[test]
fn named_block_pairs_use_their_own_models() {
    // Blocks 1–2 touch through "Soft" (k = 1), blocks 3–4 through "Stiff" (k = 7). Peridigm
    // would use the first model ("Soft") for both pairs; here each pair keeps its own. Pairs
    // that no interaction names (here 1–3, 2–4, each block with itself) use the first model,
    // as Peridigm does.
    let (rc, delta) = (0.4, 0.5);
    let contact = contact_list(
        1.0,
        1,
        &[("Soft", rc, 1.0, 0.0), ("Stiff", rc, 7.0, 0.0)],
        &(pair("One", "block_1", "block_2", "Soft") + &pair("Two", "block_3", "block_4", "Stiff")),
    );
    let s = Setup::new(
        &deck_text(4, delta, true, &contact),
        &[
            (0.0, 0.0, 0.0, 1, 1.0),
            (0.3, 0.0, 0.0, 2, 1.0),
            (10.0, 0.0, 0.0, 3, 1.0),
            (10.3, 0.0, 0.0, 4, 1.0),
        ],
    );
    let contact = s.contact();
    let mut contact_state = contact.initial_state();
    assert_eq!(contact.pair_model(0, 1).unwrap().spring_constant, 1.0);
    assert_eq!(contact.pair_model(1, 0).unwrap().spring_constant, 1.0);
    assert_eq!(contact.pair_model(2, 3).unwrap().spring_constant, 7.0);
    assert_eq!(contact.pair_model(1, 2).unwrap().spring_constant, 1.0);
    assert_eq!(contact.pair_model(3, 3).unwrap().spring_constant, 1.0);
    let y = s.model.points.position.clone();
    let v = vec![[0.0; 3]; y.len()];
    let f = contact
        .compute_force(&mut contact_state, &s.model, &y, &v)
        .to_vec();
    let soft = f[s.run(0)][0];
    let stiff = f[s.run(2)][0];
    assert!(close(soft, -expected_magnitude(1.0, rc, 0.3, delta, 1.0)));
    assert!(close(stiff, -expected_magnitude(7.0, rc, 0.3, delta, 1.0)));
    assert!(close(f[s.run(1)][0], -soft) && f[s.run(1)][1] == 0.0);
    assert!(close(f[s.run(3)][0], -stiff));
}

#[test]
fn general_and_self_contact_choose_the_models_of_their_pairs() {
    // δ = 0.2 < 0.3 = spacing < r_c = 0.4: nothing is bonded, every pair is within r_c.
    // A, B in block 1; C in block 2. Every pair touches; the first model ("One", k = 1) serves
    // pairs no interaction names, "Five" (k = 5) those an interaction gives it.
    let mesh = [
        (0.0, 0.0, 0.0, 1, 1.0),
        (0.3, 0.0, 0.0, 1, 1.0),
        (0.0, 0.3, 0.0, 2, 1.0),
    ];
    let forces = |interactions: &str| {
        let contact = contact_list(
            1.0,
            1,
            &[("One", 0.4, 1.0, 0.0), ("Five", 0.4, 5.0, 0.0)],
            interactions,
        );
        let s = Setup::new(&deck_text(2, 0.2, false, &contact), &mesh);
        assert_eq!(s.model.bonds.num_bonds(), 0);
        let c = s.contact();
        let mut contact_state = c.initial_state();
        let y = s.model.points.position.clone();
        let v = vec![[0.0; 3]; y.len()];
        let f = c
            .compute_force(&mut contact_state, &s.model, &y, &v)
            .to_vec();
        // Force on A from B (same block, along x) and from C (other block, along y).
        f[s.run(0)]
    };
    let unit = -expected_magnitude(1.0, 0.4, 0.3, 0.2, 1.0);
    let none = forces("");
    assert!(close(none[0], unit) && close(none[1], unit), "{none:?}");
    let general = forces(&general("Five"));
    assert!(
        close(general[0], unit) && close(general[1], 5.0 * unit),
        "{general:?}"
    );
    let own = forces(&self_contact("Five"));
    assert!(close(own[0], 5.0 * unit) && close(own[1], unit), "{own:?}");
}

/// Two points of different blocks approach with ±v, touch, and separate.
/// Returns (final velocities of the two points, contact statistics).
fn rebound(search_frequency: u64) -> ([[f64; 3]; 2], peridyn::contact::ContactStatistics, f64) {
    // Relative motion inside contact: r̈ = 2 c_ij V (r_c − r)/ρ with c_ij = 18 k/(π δ⁵), so
    // ω² = 36 k V/(π δ⁵ ρ). k is chosen for ω = 100 (V = ρ = 1, δ = 0.5).
    let (delta, rc, omega, dt) = (0.5f64, 0.4, 100.0f64, 2.0e-4);
    let k = omega * omega * PI * delta.powi(5) / 36.0;
    // Search Radius = r_c: Peridigm's list would hold nothing (points start 1.0 apart) and
    // would only be refreshed every `search_frequency` steps.
    let contact = contact_list(rc, search_frequency, &[("M", rc, k, 0.0)], &general("M"));
    let s = Setup::new(
        &deck_text(2, delta, false, &contact),
        &[(0.0, 0.0, 0.0, 1, 1.0), (1.0, 0.0, 0.0, 2, 1.0)],
    );
    assert_eq!(s.model.bonds.num_bonds(), 0);
    let mut physics = s.physics();
    let (a, b) = (s.run(0), s.run(1));
    let mut state = State::at_rest(&s.model.points.position, 0.0, false)
        .with_contact(physics.contact.as_ref().map(|c| c.initial_state()));
    state.velocity[a] = [1.0, 0.0, 0.0];
    state.velocity[b] = [-1.0, 0.0, 0.0];
    // Gap to close: 1.0 − 0.4 at relative speed 2 (0.3 s), contact lasts π/ω ≈ 0.031 s.
    let steps = 2000;
    let mut integrator = VelocityVerlet::new(
        &s.model,
        VerletSettings {
            time_step: dt,
            steps,
            initial_time: 0.0,
        },
    );
    integrator
        .initialize(&s.model, &mut physics, &mut state)
        .unwrap();
    let initial_candidates = state.contact.as_ref().unwrap().statistics().candidate_pairs;
    assert_eq!(
        initial_candidates, 0,
        "points start beyond the search radius"
    );
    for step in 1..=steps {
        integrator
            .step(&s.model, &mut physics, &mut state, step)
            .unwrap();
    }
    let stats = state.contact.as_ref().unwrap().statistics();
    ([state.velocity[a], state.velocity[b]], stats, omega * dt)
}

#[test]
fn two_points_rebound_with_velocities_reversed() {
    let ([va, vb], stats, omega_dt) = rebound(1_000_000);
    // Velocity Verlet samples the contact force at step ends; entering and leaving contact
    // mid-step misplaces the impulse by O(ω²·v·Δt²), a relative velocity error of O((ωΔt)²)
    // (here (ωΔt)² = 4e-4). No damping or friction: the velocities reverse and the kinetic
    // energy ½(v_a² + v_b²) = 1 comes back within that error.
    let tolerance = 2.0 * omega_dt * omega_dt;
    assert!((va[0] + 1.0).abs() <= tolerance, "v_a = {va:?}");
    assert!((vb[0] - 1.0).abs() <= tolerance, "v_b = {vb:?}");
    assert_eq!([va[1], va[2], vb[1], vb[2]], [0.0; 4]);
    let kinetic = 0.5 * (va[0] * va[0] + vb[0] * vb[0]);
    assert!(
        (kinetic - 1.0).abs() <= 2.0 * tolerance,
        "kinetic energy {kinetic}"
    );
    // Equal and opposite throughout: momentum stays zero.
    assert!((va[0] + vb[0]).abs() < 1e-12);
    // The scheduled search never came (frequency 1e6): every search after the first was
    // forced by the skin rule.
    assert_eq!(stats.scheduled_searches, 0);
    assert!(stats.early_searches > 0, "{stats}");
}

#[test]
fn skin_rule_finds_the_pair_like_searching_every_step() {
    // Points travel 0.6 (more than the 0.4 search radius) between the initial search and the
    // contact; with searches only every 1e6 steps the skin rule must search early. The result
    // must equal searching every step, bit for bit (forces only come from pairs within r_c,
    // summed in the same order).
    let (skin, skin_stats, _) = rebound(1_000_000);
    let (every, every_stats, _) = rebound(1);
    assert_eq!(skin, every);
    assert!(every_stats.scheduled_searches == 2000, "{every_stats}");
    assert!(skin_stats.searches() < every_stats.searches());
    // And the pair really was found: the velocities reversed.
    assert!(skin[0][0] < -0.99 && skin[1][0] > 0.99);
}

#[test]
fn no_contact_section_builds_no_contact() {
    let s = Setup::new(
        &deck_text(2, 0.5, false, ""),
        &[(0.0, 0.0, 0.0, 1, 1.0), (0.3, 0.0, 0.0, 2, 1.0)],
    );
    assert!(s.physics().contact.is_none());
    assert!(Contact::from_deck(&s.deck, &s.model).unwrap().is_none());
}

#[test]
fn interaction_with_an_unknown_block_names_the_key() {
    let contact = contact_list(
        1.0,
        1,
        &[("M", 0.4, 1.0, 0.0)],
        &pair("Ball on Plate", "block_1", "block_9", "M"),
    );
    let s = Setup::new(
        &deck_text(2, 0.5, false, &contact),
        &[(0.0, 0.0, 0.0, 1, 1.0), (3.0, 0.0, 0.0, 2, 1.0)],
    );
    let message = Contact::from_deck(&s.deck, &s.model)
        .unwrap_err()
        .to_string();
    assert!(
        message.contains("Ball on Plate")
            && message.contains("Second Block")
            && message.contains("block_9")
            && message.contains("block_1, block_2"),
        "{message}"
    );
}

#[test]
fn search_radius_includes_the_skin_and_the_deck_value_when_larger() {
    // r_c = 0.4, skin ½ r_c: R = max(Search Radius, 0.6).
    for (deck_radius, expected) in [(0.4, 0.6000000000000001), (2.0, 2.0)] {
        let contact = contact_list(deck_radius, 5, &[("M", 0.4, 1.0, 0.0)], &general("M"));
        let s = Setup::new(
            &deck_text(2, 0.5, false, &contact),
            &[(0.0, 0.0, 0.0, 1, 1.0), (3.0, 0.0, 0.0, 2, 1.0)],
        );
        let c = s.contact();
        assert_eq!(c.search_radius(), expected);
        assert_eq!(c.search_frequency(), 5);
    }
}

/// The contact list of one `Time Dependent Short Range Force` model "M" (r_c = 0.4, k = 3)
/// whose `Friction Coefficient` is `friction` (an expression in t), between all blocks.
fn time_dependent_contact(friction: &str) -> String {
    format!(
        "  Contact:\n    Search Radius: 1.0\n    Search Frequency: 1\n    Models:\n      M:\n        Contact Model: \"Time Dependent Short Range Force\"\n        Contact Radius: 0.4\n        Spring Constant: 3.0\n        Friction Coefficient: \"{friction}\"\n    Interactions:\n{}",
        general("M")
    )
}

/// Force densities of two sliding points 0.3 apart (inside r_c = 0.4) in the deck whose
/// contact list is `contact`, with the contact's time set to `time` first when given.
fn sliding_pair_force(contact: &str, time: Option<f64>) -> Vec<[f64; 3]> {
    let s = Setup::new(
        &deck_text(2, 0.5, true, contact),
        &[(0.0, 0.0, 0.0, 1, 1.0), (0.3, 0.0, 0.0, 2, 2.0)],
    );
    let mut contact = s.contact();
    if let Some(t) = time {
        contact.set_time(t).unwrap_or_else(|e| panic!("{e}"));
    }
    let mut state = contact.initial_state();
    let y = s.model.points.position.clone();
    let mut v = vec![[0.0; 3]; 2];
    v[s.run(0)] = [1.0, 2.0, 0.5];
    v[s.run(1)] = [0.0, -1.0, 0.0];
    contact.compute_force(&mut state, &s.model, &y, &v).to_vec()
}

#[test]
fn time_dependent_friction_equals_the_constant_coefficient_at_each_time() {
    // μ(t) = t/2 takes the values 0.125, 0.25 and 0.75 exactly at t = 0.25, 0.5 and 1.5 (binary
    // fractions), so at each of those times the force must be, bit for bit, that of `Short
    // Range Force` with that constant coefficient (the same pair law is evaluated).
    let in_time = time_dependent_contact("value = t / 2.0");
    for (t, mu) in [(0.25, 0.125), (0.5, 0.25), (1.5, 0.75)] {
        let constant = contact_list(1.0, 1, &[("M", 0.4, 3.0, mu)], &general("M"));
        let expected = sliding_pair_force(&constant, None);
        assert_eq!(sliding_pair_force(&in_time, Some(t)), expected, "t = {t}");
        // Friction really acts: the force has a tangential part μ|F_n|.
        assert!(expected.iter().any(|f| f[1] != 0.0), "t = {t}");
    }
    // Before any step the coefficient is the value at the first solver's initial time (0):
    // no friction, the force of μ = 0.
    let frictionless = contact_list(1.0, 1, &[("M", 0.4, 3.0, 0.0)], &general("M"));
    assert_eq!(
        sliding_pair_force(&in_time, None),
        sliding_pair_force(&frictionless, None)
    );
}

#[test]
fn a_negative_or_failing_friction_coefficient_names_the_key_and_the_time() {
    let contact = time_dependent_contact("value = 1.0 - t");
    let s = Setup::new(
        &deck_text(2, 0.5, true, &contact),
        &[(0.0, 0.0, 0.0, 1, 1.0), (3.0, 0.0, 0.0, 2, 1.0)],
    );
    let mut c = s.contact();
    c.set_time(0.5).unwrap();
    let message = c.set_time(2.0).unwrap_err().to_string();
    assert!(
        message.contains("Contact → Models → M → Friction Coefficient")
            && message.contains("t = 2")
            && message.contains("-1"),
        "{message}"
    );
    // Negative from the start: refused at setup, naming the key.
    let contact = time_dependent_contact("value = t - 1.0");
    let s = Setup::new(
        &deck_text(2, 0.5, true, &contact),
        &[(0.0, 0.0, 0.0, 1, 1.0), (3.0, 0.0, 0.0, 2, 1.0)],
    );
    let message = Contact::from_deck(&s.deck, &s.model)
        .unwrap_err()
        .to_string();
    assert!(
        message.contains("Friction Coefficient") && message.contains("-1"),
        "{message}"
    );
}
