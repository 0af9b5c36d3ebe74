//! Short-range contact for explicit dynamics (Peridigm's `Contact` list,
//! `Peridigm_ContactManager.cpp`; Littlewood's "Roadmap for Software Implementation", 2016,
//! Algorithm 4).
//!
//! Built only when the deck has a `Contact` section; without one nothing here is allocated or
//! run.
//!
//! # Who touches whom
//!
//! As in Peridigm, every two points that are not bonded in the reference configuration (in
//! either one's family) are in contact, whatever their blocks, so fragments of one block
//! collide with each other; they stay excluded after their bond breaks. `Contact →
//! Interactions` chooses the model of each pair of blocks: pairs no interaction names use the
//! first entry of `Models`; `General Contact` sets the model of every two *different* blocks,
//! `Self Contact` that of each block with itself, and a named entry (`First Block`, `Second
//! Block`, `Contact Model`) that of its two blocks (or one block with itself when both names
//! agree). Named entries override `General` / `Self Contact`; when two name the same pair, the
//! later one in the file wins.
//!
//! ## Differences from Peridigm (deliberate)
//!
//! * Peridigm uses the **first** entry of `Models` for every pair (comment "assume that there
//!   is only one contact model"); here each interaction's model is used for its pairs.
//! * Peridigm's contact neighbour list is only refreshed every `Search Frequency` steps, with
//!   no regard to how far points move in between, so it misses pairs that close in from
//!   beyond `Search Radius`. Here the skin rule below guarantees that no pair is missed.
//!
//! # The force
//!
//! [`ShortRangeForce`]: for pairs closer than the contact radius r_c in the current
//! configuration, a repulsive force along the line of centres, proportional to the gap
//! r_c − r, with Peridigm's constants, plus Peridigm's friction. `Time Dependent Short Range
//! Force` is the same law with the friction coefficient μ_f(t) of an expression in `t`,
//! evaluated once per step ([`Contact::set_time`]).
//! Contact forces enter the Verlet acceleration `a = (f_int + f_contact + b)/ρ` after damage
//! and the internal force, as in Peridigm.
//!
//! # The proximity search and the skin rule
//!
//! Candidates are found in the current configuration with a search radius
//! R = max(`Search Radius`, r_c,max + s), where r_c,max is the largest contact radius of the
//! models in use and the skin is s = [`SKIN_FRACTION`] · r_c,max. The list holds every allowed
//! pair within R of each other at the last search. The search runs
//!
//! * before the first force evaluation of the run,
//! * at the start of every step whose number is a multiple of `Search Frequency` (Peridigm's
//!   schedule, with the positions at the start of the step), and
//! * early, just before a force evaluation, whenever 2·d_max > R − r_c,max, where d_max is the
//!   largest displacement of any contact point since the last search.
//!
//! Why the last rule is enough: a pair missing from the list was more than R apart at the last
//! search; each point has moved at most d_max since, so they are now more than R − 2·d_max ≥
//! r_c,max apart and carry no force. The check costs one pass over the contact points per step.
//! The log reports how many searches ran (scheduled and early) and the candidate-pair count.
//!
//! # On N ranks
//! [`Contact::on_ranks`] gives one rank of a distributed run the one-rank candidate rows of its
//! owned points and bitwise the one-rank forces: every search gathers the positions of all
//! contact points on every rank (O(N) messages per search; searches are rare), the skin rule
//! takes the largest displacement over all ranks, and a per-step exchange rebuilt with each
//! search brings the off-rank partners' positions and velocities. Each point's force is the
//! sum of the pair law over its candidate row, in row (global run) order, on one rank and on
//! N alike.

mod ranks;
mod restart;
mod search;
mod short_range_force;

pub use search::{
    find_candidates, find_candidates_for, max_displacement, CandidateList, OneWayBonds,
};
pub use short_range_force::{PairPoint, ShortRangeForce};

use crate::expression::{Expression, TIME};
use crate::io::deck::{ContactInteraction, Deck, DeckError, Friction};
use crate::model::Model;
use crate::neighbors::SearchBackend;
use rayon::prelude::*;
use std::fmt;
use std::time::Instant;

/// Skin s as a fraction of the largest contact radius: the search radius is at least
/// r_c,max·(1 + `SKIN_FRACTION`), so that a search stays valid until some point has moved a
/// quarter of the contact radius, even when the deck's `Search Radius` equals the contact radius.
pub const SKIN_FRACTION: f64 = 0.5;

/// Search counts and list sizes, for the run log.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ContactStatistics {
    /// Searches before the first force evaluation (one per run).
    pub initial_searches: u64,
    /// Searches on `Search Frequency`'s schedule.
    pub scheduled_searches: u64,
    /// Searches forced by the skin rule between scheduled ones.
    pub early_searches: u64,
    /// Candidate pairs found by the last search.
    pub candidate_pairs: usize,
    /// Largest candidate-pair count of any search.
    pub max_candidate_pairs: usize,
    /// Pairs closer than their contact radius at the last force evaluation.
    pub pairs_in_contact: usize,
    /// Wall-clock seconds spent searching.
    pub search_seconds: f64,
}

impl ContactStatistics {
    /// All searches.
    pub fn searches(&self) -> u64 {
        self.initial_searches + self.scheduled_searches + self.early_searches
    }
}

/// The contact of a run: settings, pair models and the points that take part, fixed after
/// setup. What changes during the run (the last search, the contact force) is its
/// [`ContactState`], part of the run's [`crate::state::State`].
#[derive(Debug, Clone)]
pub struct Contact {
    /// `Search Frequency` (steps, ≥ 1).
    search_frequency: u64,
    /// R = max(`Search Radius`, r_c,max·(1 + [`SKIN_FRACTION`])) (length).
    search_radius: f64,
    /// Largest contact radius of the models in use (length).
    max_contact_radius: f64,
    /// Models referenced by interactions, with the friction coefficient in force now.
    models: Vec<ShortRangeForce>,
    /// Per model: its time-dependent `Friction Coefficient` μ_f(t) (`Time Dependent Short
    /// Range Force`), which [`Contact::set_time`] evaluates into the model; `None` for a
    /// constant coefficient.
    friction_in_time: Vec<Option<FrictionInTime>>,
    /// `pair_model[a·blocks + b]`: the model of blocks a and b (symmetric), if they interact.
    pair_model: Vec<Option<u16>>,
    blocks: usize,
    /// Points of blocks with any interaction (ascending run order).
    points: Vec<u32>,
    /// Bonds without a reverse (so that the search strikes out bonded pairs from one side).
    one_way_bonds: OneWayBonds,
    backend: SearchBackend,
    /// Points of the model the contact force density covers (the rank's local points on
    /// ranks).
    force_points: usize,
    /// One rank's share of a distributed run (`None` in serial runs).
    ranks: Option<Box<ranks::OnRanks>>,
}

/// The `Friction Coefficient` of a `Time Dependent Short Range Force` model: an expression in
/// `t`, evaluated once per step at the time the step ends (Peridigm evaluates it with the
/// step's end time before the contact force of the step).
#[derive(Debug, Clone)]
struct FrictionInTime {
    /// The model's name (its list under `Contact → Models`), for messages.
    model: String,
    expression: Expression,
}

impl FrictionInTime {
    /// μ_f(t): a finite number ≥ 0, or a message saying what the expression gave.
    fn at(&self, time: f64) -> Result<f64, FrictionError> {
        let fail = |message: String| FrictionError {
            model: self.model.clone(),
            time,
            message,
        };
        let mu = self
            .expression
            .eval(&[time])
            .map_err(|e| fail(e.to_string()))?;
        if mu.is_finite() && mu >= 0.0 {
            Ok(mu)
        } else {
            Err(fail(format!(
                "the friction coefficient evaluates to {mu}; it must be a finite number ≥ 0"
            )))
        }
    }
}

/// A time-dependent friction coefficient that could not be evaluated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("Contact → Models → {model} → Friction Coefficient at t = {time}: {message}")]
pub struct FrictionError {
    /// The contact model (its list under `Contact → Models`).
    pub model: String,
    /// The time of the evaluation.
    pub time: f64,
    /// What went wrong.
    pub message: String,
}

/// What contact changes during a run: the last search (positions and candidate rows), the
/// contact force of the last evaluation and the counts for the log; on ranks also the partner
/// exchange of the last search. Made by [`Contact::initial_state`]; a default value is a
/// state without contact.
#[derive(Debug, Clone, Default)]
pub struct ContactState {
    /// Positions of the contact points (the owned ones on ranks) at the last search.
    searched_at: Vec<[f64; 3]>,
    /// The candidate rows of the last search (`None` before the first).
    candidates: Option<CandidateList>,
    /// Contact force density of every point (force/length³).
    force_density: Vec<[f64; 3]>,
    statistics: ContactStatistics,
    /// One rank's partner exchange (`None` in serial runs).
    ranks: Option<Box<ranks::RankState>>,
}

impl ContactState {
    /// The candidate list of the last search (`None` before the first).
    pub fn candidates(&self) -> Option<&CandidateList> {
        self.candidates.as_ref()
    }

    /// Contact force density of every point at the last evaluation (force/length³).
    pub fn force_density(&self) -> &[[f64; 3]] {
        &self.force_density
    }

    /// Search counts and list sizes so far.
    pub fn statistics(&self) -> ContactStatistics {
        self.statistics
    }

    /// Records a search that found `list` and took `seconds`.
    fn searched(&mut self, list: CandidateList, seconds: f64) {
        self.statistics.candidate_pairs = list.pairs();
        self.statistics.max_candidate_pairs = self.statistics.max_candidate_pairs.max(list.pairs());
        self.statistics.search_seconds += seconds;
        self.candidates = Some(list);
    }
}

/// The pair laws: which model acts between two blocks.
#[derive(Clone, Copy)]
struct PairLaws<'a> {
    models: &'a [ShortRangeForce],
    pair_model: &'a [Option<u16>],
    blocks: usize,
}

/// Per-point data the pair law reads, indexed by point (run order, or global order on ranks).
#[derive(Clone, Copy)]
struct PointData<'a> {
    block: &'a [u32],
    horizon: &'a [f64],
    volume: &'a [f64],
    current: &'a [[f64; 3]],
    velocity: &'a [[f64; 3]],
}

/// Contact force density on point `i` from the candidates `row` (ascending): the sum over the
/// row in its order, so a point's force depends on its candidate row alone (the same on one
/// rank and on N). Returns the force density and the number of candidates in contact.
///
/// Quick reject on the squared distance q = |y_j − y_i|² (the very number whose root the pair
/// law takes): with t = fl(fl(r_c,max²)·(1 + 2⁻³⁰)) ≥ r_c,max²(1 − u)³(1 + 2⁻³⁰) > r_c,max²
/// (u = 2⁻⁵³), q > t implies √q > r_c,max, so the law's fl(√q) ≥ r_c,max (rounding is monotone
/// and r_c,max is a float) ≥ its r_c and it returns no force. Rejecting here only skips work:
/// the forces are bitwise those of the law alone.
#[inline(always)]
fn force_on_point(
    laws: PairLaws<'_>,
    points: PointData<'_>,
    reject_beyond: f64,
    i: usize,
    row: &[u32],
) -> ([f64; 3], usize) {
    let mut f = [0.0; 3];
    if row.is_empty() {
        return (f, 0);
    }
    let point = |p: usize| PairPoint {
        position: points.current[p],
        velocity: points.velocity[p],
        horizon: points.horizon[p],
        volume: points.volume[p],
    };
    let a = points.block[i] as usize;
    let me = point(i);
    let mut touching = 0;
    for &j in row {
        let j = j as usize;
        let yj = points.current[j];
        let d = [
            yj[0] - me.position[0],
            yj[1] - me.position[1],
            yj[2] - me.position[2],
        ];
        if d[0] * d[0] + d[1] * d[1] + d[2] * d[2] > reject_beyond {
            continue;
        }
        let b = points.block[j] as usize;
        let law = &laws.models
            [laws.pair_model[a * laws.blocks + b].expect("filtered by search") as usize];
        if let Some(g) = law.force_density_on(&me, &point(j)) {
            for k in 0..3 {
                f[k] += g[k];
            }
            touching += 1;
        }
    }
    (f, touching)
}

/// The contact models the interactions use, each once, in order of first use.
struct ModelsInUse<'d> {
    deck: &'d Deck,
    contact: &'d crate::io::deck::Contact,
    models: Vec<ShortRangeForce>,
    friction_in_time: Vec<Option<FrictionInTime>>,
    /// The deck names of `models`.
    used: Vec<&'d str>,
    /// The time of the first force evaluation, where a time-dependent friction coefficient
    /// starts.
    initial_time: f64,
}

impl ModelsInUse<'_> {
    /// The index of the model `name` that interaction `entry` names, adding it on first use.
    fn index(&mut self, entry: &str, name: &str) -> Result<u16, DeckError> {
        let deck = self.deck;
        if let Some(k) = self.used.iter().position(|u| *u == name) {
            return Ok(k as u16);
        }
        let definition = self
            .contact
            .models
            .iter()
            .find(|m| m.name == name)
            .ok_or_else(|| {
                deck.error_at(
                    &["Contact", "Interactions", entry, "Contact Model"],
                    format!("no contact model named \"{name}\""),
                )
            })?;
        let key = ["Contact", "Models", name, "Friction Coefficient"];
        let (friction_coefficient, in_time) = match &definition.friction {
            Friction::Constant(mu) => (*mu, None),
            Friction::TimeDependent(text) => {
                let friction = FrictionInTime {
                    model: definition.name.clone(),
                    expression: Expression::parse(text, TIME)
                        .map_err(|e| deck.error_at(&key, e.to_string()))?,
                };
                let mu = friction
                    .at(self.initial_time)
                    .map_err(|e| deck.error_at(&key, e.to_string()))?;
                (mu, Some(friction))
            }
        };
        self.models.push(ShortRangeForce {
            contact_radius: definition.contact_radius,
            spring_constant: definition.spring_constant,
            friction_coefficient,
        });
        self.friction_in_time.push(in_time);
        self.used.push(&definition.name);
        Ok((self.models.len() - 1) as u16)
    }
}

/// The index of the block `name` that key `key` of interaction `entry` names.
fn block_index(
    deck: &Deck,
    model: &Model,
    entry: &str,
    key: &str,
    name: &str,
) -> Result<usize, DeckError> {
    model
        .blocks
        .iter()
        .position(|b| b.info.name == name)
        .ok_or_else(|| {
            deck.error_at(
                &["Contact", "Interactions", entry, key],
                format!(
                    "the mesh has no block \"{name}\"; its blocks are {}",
                    model
                        .blocks
                        .iter()
                        .map(|b| b.info.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            )
        })
}

/// The model of every (block, block) pair, row-major, `None` where the blocks do not touch.
///
/// As in Peridigm, every pair of blocks (each block with itself included) is in contact,
/// through the first model of `Models`; then General and Self Contact, then named pairs
/// in file order (later ones win) choose the model of their pairs. Peridigm uses the
/// first model for every pair whatever the interactions say; that part is not kept.
fn pair_models(in_use: &mut ModelsInUse, model: &Model) -> Result<Vec<Option<u16>>, DeckError> {
    let (deck, contact) = (in_use.deck, in_use.contact);
    let blocks = model.blocks.len();
    let default_model = match contact.models.first() {
        Some(first) => Some(in_use.index("Models", &first.name)?),
        None => None,
    };
    let mut pair_model: Vec<Option<u16>> = vec![default_model; blocks * blocks];
    for interaction in &contact.interactions {
        match interaction {
            ContactInteraction::General { model } => {
                let m = in_use.index("General Contact", model)?;
                for a in 0..blocks {
                    for b in (0..blocks).filter(|&b| b != a) {
                        pair_model[a * blocks + b] = Some(m);
                    }
                }
            }
            ContactInteraction::SelfContact { model } => {
                let m = in_use.index("Self Contact", model)?;
                for a in 0..blocks {
                    pair_model[a * blocks + a] = Some(m);
                }
            }
            ContactInteraction::Pair { .. } => {}
        }
    }
    for interaction in &contact.interactions {
        if let ContactInteraction::Pair {
            name,
            first_block,
            second_block,
            model: pair,
        } = interaction
        {
            let a = block_index(deck, model, name, "First Block", first_block)?;
            let b = block_index(deck, model, name, "Second Block", second_block)?;
            let m = in_use.index(name, pair)?;
            pair_model[a * blocks + b] = Some(m);
            pair_model[b * blocks + a] = Some(m);
        }
    }
    Ok(pair_model)
}

impl Contact {
    /// The contact of `deck` for `model`, or `None` without a `Contact` section. Errors name
    /// the deck key: an interaction naming a block the mesh lacks, or a time-dependent friction
    /// coefficient that does not compile or is not a number ≥ 0 at the first solver's initial
    /// time.
    pub fn from_deck(deck: &Deck, model: &Model) -> Result<Option<Self>, DeckError> {
        let Some(contact) = &deck.contact else {
            return Ok(None);
        };
        let blocks = model.blocks.len();
        let mut in_use = ModelsInUse {
            deck,
            contact,
            models: Vec::new(),
            friction_in_time: Vec::new(),
            used: Vec::new(),
            initial_time: deck.solvers.first().map_or(0.0, |s| s.initial_time),
        };
        let pair_model = pair_models(&mut in_use, model)?;
        let (models, friction_in_time) = (in_use.models, in_use.friction_in_time);
        let in_contact: Vec<bool> = (0..blocks)
            .map(|a| (0..blocks).any(|b| pair_model[a * blocks + b].is_some()))
            .collect();
        let points: Vec<u32> = (0..model.points.len() as u32)
            .filter(|&p| in_contact[model.points.block[p as usize] as usize])
            .collect();
        let max_contact_radius = models.iter().map(|m| m.contact_radius).fold(0.0, f64::max);
        let search_radius = contact
            .search_radius
            .max(max_contact_radius * (1.0 + SKIN_FRACTION));
        Ok(Some(Self {
            search_frequency: contact.search_frequency.max(1),
            search_radius,
            max_contact_radius,
            models,
            friction_in_time,
            pair_model,
            blocks,
            points,
            one_way_bonds: OneWayBonds::new(&model.bonds),
            backend: SearchBackend::Auto,
            force_points: model.points.len(),
            ranks: None,
        }))
    }

    /// The state of a run before its first search: no candidates, no force.
    pub fn initial_state(&self) -> ContactState {
        ContactState {
            force_density: vec![[0.0; 3]; self.force_points],
            ranks: self
                .ranks
                .as_deref()
                .map(|ranks| Box::new(ranks.initial_state())),
            ..ContactState::default()
        }
    }

    /// Sets the time of the next force evaluation: every `Time Dependent Short Range Force`
    /// model takes its friction coefficient μ_f(t); the other models do not change.
    pub fn set_time(&mut self, time: f64) -> Result<(), FrictionError> {
        for (law, friction) in self.models.iter_mut().zip(&self.friction_in_time) {
            if let Some(friction) = friction {
                law.friction_coefficient = friction.at(time)?;
            }
        }
        Ok(())
    }

    /// Search radius R actually used (length): max(`Search Radius`, r_c,max(1 + skin fraction)).
    pub fn search_radius(&self) -> f64 {
        self.search_radius
    }

    /// Largest contact radius of the models in use (length).
    pub fn max_contact_radius(&self) -> f64 {
        self.max_contact_radius
    }

    /// `Search Frequency` (steps).
    pub fn search_frequency(&self) -> u64 {
        self.search_frequency
    }

    /// The model that acts between blocks `a` and `b` (model block indices), if any.
    pub fn pair_model(&self, a: usize, b: usize) -> Option<&ShortRangeForce> {
        self.pair_model[a * self.blocks + b].map(|m| &self.models[m as usize])
    }

    /// Points that take part in contact (ascending run order).
    pub fn points(&self) -> &[u32] {
        &self.points
    }

    /// Sets the search structure (for benchmarks and cross-checks; results do not depend on it).
    pub fn set_search_backend(&mut self, backend: SearchBackend) {
        self.backend = backend;
    }

    /// True when points i and j (run order) may touch: their blocks interact and they are not
    /// bonded in the reference configuration (in either family).
    pub fn may_touch(&self, model: &Model, i: usize, j: usize) -> bool {
        self.blocks_interact(model, i, j)
            && model.bonds.family(i).binary_search(&(j as u32)).is_err()
            && model.bonds.family(j).binary_search(&(i as u32)).is_err()
    }

    /// True when the blocks of points i and j have a contact model between them.
    fn blocks_interact(&self, model: &Model, i: usize, j: usize) -> bool {
        let (a, b) = (
            model.points.block[i] as usize,
            model.points.block[j] as usize,
        );
        self.pair_model[a * self.blocks + b].is_some()
    }

    /// Squared-distance bound beyond which no pair law acts (see [`force_on_point`]).
    fn reject_beyond(&self) -> f64 {
        self.max_contact_radius * self.max_contact_radius * (1.0 + 1.0 / (1u64 << 30) as f64)
    }

    /// Searches now at `current` (positions of every point, run order).
    pub fn search(&self, state: &mut ContactState, model: &Model, current: &[[f64; 3]]) {
        assert!(
            self.ranks.is_none(),
            "the contact of a distributed run searches through search_on_ranks"
        );
        let start = Instant::now();
        let list = find_candidates(
            &self.points,
            current,
            self.search_radius,
            self.backend,
            Some((&model.bonds, &self.one_way_bonds)),
            |i, j| self.blocks_interact(model, i, j),
        );
        state.searched_at = self.points.iter().map(|&p| current[p as usize]).collect();
        state.searched(list, start.elapsed().as_secs_f64());
    }

    /// Peridigm's schedule: searches at the start of step `step` (1-based) when it is a
    /// multiple of `Search Frequency`, with the positions at the start of the step.
    pub fn scheduled_search(
        &self,
        state: &mut ContactState,
        step: u64,
        model: &Model,
        current: &[[f64; 3]],
    ) {
        if step % self.search_frequency == 0 {
            self.search(state, model, current);
            state.statistics.scheduled_searches += 1;
        }
    }

    /// True when the candidate list may miss a pair at `current`: no search yet, or some point
    /// moved more than (R − r_c,max)/2 since the last one.
    pub fn needs_search(&self, state: &ContactState, current: &[[f64; 3]]) -> bool {
        state.candidates.is_none()
            || 2.0 * max_displacement(&self.points, &state.searched_at, current)
                > self.search_radius - self.max_contact_radius
    }

    /// The contact models and which pair of blocks uses which.
    fn laws(&self) -> PairLaws<'_> {
        PairLaws {
            models: &self.models,
            pair_model: &self.pair_model,
            blocks: self.blocks,
        }
    }

    /// Contact force density at positions `current` and velocities `velocity` (the mid-step
    /// velocity inside a Verlet step, as in Peridigm), after searching first if the skin rule
    /// asks for it. Returns the force density of every point.
    pub fn compute_force<'s>(
        &self,
        state: &'s mut ContactState,
        model: &Model,
        current: &[[f64; 3]],
        velocity: &[[f64; 3]],
    ) -> &'s [[f64; 3]] {
        assert!(
            self.ranks.is_none(),
            "the contact of a distributed run computes through compute_force_on_ranks"
        );
        if state.candidates.is_none() {
            self.search(state, model, current);
            state.statistics.initial_searches += 1;
        } else if self.needs_search(state, current) {
            self.search(state, model, current);
            state.statistics.early_searches += 1;
        }
        let candidates = state.candidates.as_ref().expect("searched above");
        let laws = self.laws();
        let points = PointData {
            block: &model.points.block,
            horizon: &model.horizon,
            volume: &model.points.volume,
            current,
            velocity,
        };
        let reject_beyond = self.reject_beyond();
        let in_contact: usize = state
            .force_density
            .par_iter_mut()
            .enumerate()
            .map(|(i, f)| {
                let (force, touching) =
                    force_on_point(laws, points, reject_beyond, i, candidates.row(i));
                *f = force;
                touching
            })
            .sum();
        state.statistics.pairs_in_contact = in_contact / 2;
        &state.force_density
    }
}

impl fmt::Display for ContactStatistics {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} searches ({} initial, {} scheduled, {} early by the skin rule, {:.3} s), {} candidate pairs at the last search (max {}), {} pairs in contact at the last step",
            self.searches(),
            self.initial_searches,
            self.scheduled_searches,
            self.early_searches,
            self.search_seconds,
            self.candidate_pairs,
            self.max_candidate_pairs,
            self.pairs_in_contact
        )
    }
}
