//! Where the body is now: everything of a run that evolves, in one object (run order, one entry
//! per point or per directed bond).
//!
//! The model (points, bonds, blocks) is immutable after setup; the state is what changes:
//! kinematics, forces, bond damage, material history and contact's last search. Fields that a step may change and
//! then either accept or abandon are [`Staged`]: they hold the trial values every force
//! evaluation reads and writes, and, while a solver asks for it, a committed copy. Commit and
//! restore are one operation on the whole state ([`State::commit`], [`State::restore`]):
//!
//! - explicit steps commit every step; nothing keeps a committed copy there, so committing
//!   costs nothing;
//! - implicit load steps and Newmark-β steps keep a committed copy from the start of each
//!   step ([`State::keep_committed`]), restore before each residual (bonds broken by an
//!   unconverged iterate heal, as in Peridigm) and commit when a step is accepted.
//!
//! A restart file writes this one object.

use crate::contact::ContactState;
#[cfg(test)]
use crate::history::{FieldCarrier, FieldDeclaration};
pub use crate::history::{History, Staged, NO_HISTORY};

/// Everything of a run that evolves. Fields exist only when the run needs them (the external
/// force only with a body force, bond damage only with a damage model, history only for the
/// fields its models declare, contact only with a `Contact` section).
#[derive(Debug, Clone, Default)]
pub struct State {
    /// Time t (s).
    pub time: f64,
    /// Displacement u (length).
    pub displacement: Vec<[f64; 3]>,
    /// Velocity v (length/s).
    pub velocity: Vec<[f64; 3]>,
    /// Acceleration a = (f_int + b)/ρ (length/s²).
    pub acceleration: Vec<[f64; 3]>,
    /// Internal force density f_int (force/length³).
    pub force_density: Vec<[f64; 3]>,
    /// External (body) force density b (force/length³), when the deck has a body force.
    pub external_force_density: Option<Vec<[f64; 3]>>,
    /// Current positions Y = X + u (length), refreshed before every force evaluation.
    pub current_position: Vec<[f64; 3]>,
    /// Bond damage d ∈ [0, 1] per directed bond (the bond list's order), when some block has a
    /// damage model.
    pub bond_damage: Option<Staged<f32>>,
    /// Material history fields the models declared.
    pub history: History,
    /// Contact's last search and force ([`crate::contact::Contact::initial_state`]), when the
    /// run has contact. Explicit steps only, which commit every step: not staged.
    pub contact: Option<ContactState>,
    /// u_n, the displacement at the start of the quasi-static load step being solved (`None`
    /// outside one). While set, [`State::update_current_position`] forms Y as Peridigm's
    /// quasi-static solver does, from the step's start and its increment.
    pub step_start: Option<Vec<[f64; 3]>>,
}

impl State {
    /// A body at rest in the reference configuration.
    pub fn at_rest(reference: &[[f64; 3]], time: f64, body_force: bool) -> Self {
        let n = reference.len();
        Self {
            time,
            displacement: vec![[0.0; 3]; n],
            velocity: vec![[0.0; 3]; n],
            acceleration: vec![[0.0; 3]; n],
            force_density: vec![[0.0; 3]; n],
            external_force_density: body_force.then(|| vec![[0.0; 3]; n]),
            current_position: reference.to_vec(),
            bond_damage: None,
            history: History::default(),
            contact: None,
            step_start: None,
        }
    }

    /// The same state with intact bond damage (d = 0) for `bonds` directed bonds when `bonds`
    /// is given (some block has a damage model).
    pub fn with_bond_damage(mut self, bonds: Option<usize>) -> Self {
        self.bond_damage = bonds.map(|len| Staged::filled(len, 0.0));
        self
    }

    /// The same state with `contact` (`Some` exactly when the run has contact).
    pub fn with_contact(mut self, contact: Option<ContactState>) -> Self {
        self.contact = contact;
        self
    }

    /// Y = X + u; inside a quasi-static load step ([`State::step_start`] set) rounded as
    /// Peridigm's solver rounds it, `Y = (X + u_n) + (u − u_n)`. The two differ in the last bit
    /// only, but quantities that cancel to second order in the motion (the dilatation of a
    /// simple shear, and the forces of interior points that follow from it) amplify that bit
    /// to their own size, and Peridigm's gold files compare them relatively.
    pub fn update_current_position(&mut self, reference: &[[f64; 3]]) {
        match &self.step_start {
            None => {
                for ((y, x), u) in self
                    .current_position
                    .iter_mut()
                    .zip(reference)
                    .zip(&self.displacement)
                {
                    *y = [x[0] + u[0], x[1] + u[1], x[2] + u[2]];
                }
            }
            Some(start) => {
                for (((y, x), u), s) in self
                    .current_position
                    .iter_mut()
                    .zip(reference)
                    .zip(&self.displacement)
                    .zip(start)
                {
                    *y = [0, 1, 2].map(|k| (x[k] + s[k]) + (u[k] - s[k]));
                }
            }
        }
    }

    /// The bond damage that force evaluations read, if any.
    pub fn bond_damage(&self) -> Option<&[f32]> {
        self.bond_damage.as_ref().map(Staged::trial)
    }

    /// From now on keep committed copies of every staged field (implicit solvers; equal to
    /// the trial values now).
    pub fn keep_committed(&mut self) {
        self.each_staged(Staged::keep_committed, Staged::keep_committed);
    }

    /// Stops keeping committed copies (the trial values are accepted as they are). The
    /// history accepts its trial values and keeps its copy (see [`History`]).
    pub fn drop_committed(&mut self) {
        self.each_staged(Staged::drop_committed, Staged::commit);
    }

    /// Accepts every staged field's trial values (a step converged).
    pub fn commit(&mut self) {
        self.each_staged(Staged::commit, Staged::commit);
    }

    /// Puts every staged field back to its committed values (a step is redone, or an
    /// iterate is abandoned).
    pub fn restore(&mut self) {
        self.each_staged(Staged::restore, Staged::restore);
    }

    /// Applies one operation to every staged field: the bond damage (`f32`) and the history
    /// (`f64`).
    fn each_staged(&mut self, damage: fn(&mut Staged<f32>), history: fn(&mut Staged<f64>)) {
        if let Some(bond_damage) = &mut self.bond_damage {
            damage(bond_damage);
        }
        self.history.each(history);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PLASTIC: FieldDeclaration = FieldDeclaration {
        name: "Deviatoric_Plastic_Extension",
        carrier: FieldCarrier::Bond,
        bytes_per_value: 8,
        staged: true,
    };
    const LAMBDA: FieldDeclaration = FieldDeclaration {
        name: "Lambda",
        carrier: FieldCarrier::Point,
        bytes_per_value: 8,
        staged: true,
    };
    /// Recomputed in every evaluation: not history.
    const DILATATION: FieldDeclaration = FieldDeclaration {
        name: "Dilatation",
        carrier: FieldCarrier::Point,
        bytes_per_value: 8,
        staged: false,
    };

    fn damaged_state() -> State {
        let mut state = State::at_rest(&[[0.0; 3]; 2], 0.0, false).with_bond_damage(Some(3));
        state.history = History::allocate(&[PLASTIC, DILATATION, LAMBDA, PLASTIC], 2, 3);
        state
    }

    #[test]
    fn without_a_committed_copy_commit_and_restore_keep_the_trial_values() {
        let mut state = damaged_state();
        state.bond_damage.as_mut().unwrap().trial_mut()[1] = 1.0;
        state.restore();
        assert_eq!(state.bond_damage(), Some(&[0.0, 1.0, 0.0][..]));
        state.commit();
        assert_eq!(
            state.bond_damage.as_ref().unwrap().committed(),
            &[0.0, 1.0, 0.0]
        );
    }

    #[test]
    fn restore_abandons_every_staged_field_and_commit_accepts_them() {
        let mut state = damaged_state();
        state.keep_committed();
        state.bond_damage.as_mut().unwrap().trial_mut()[0] = 1.0;
        state.history.field_mut("Lambda").unwrap().trial_mut()[1] = 0.5;
        state.restore();
        assert_eq!(state.bond_damage(), Some(&[0.0, 0.0, 0.0][..]));
        assert_eq!(state.history.field("Lambda").unwrap().trial(), &[0.0, 0.0]);

        state.bond_damage.as_mut().unwrap().trial_mut()[2] = 1.0;
        state
            .history
            .field_mut("Deviatoric_Plastic_Extension")
            .unwrap()
            .trial_mut()[0] = 0.25;
        state.commit();
        state.restore();
        assert_eq!(state.bond_damage(), Some(&[0.0, 0.0, 1.0][..]));
        assert_eq!(
            state
                .history
                .field("Deviatoric_Plastic_Extension")
                .unwrap()
                .trial(),
            &[0.25, 0.0, 0.0]
        );
    }

    #[test]
    fn dropping_the_committed_copy_accepts_the_trial_values() {
        let mut state = damaged_state();
        state.keep_committed();
        state.bond_damage.as_mut().unwrap().trial_mut()[0] = 1.0;
        state.drop_committed();
        state.restore();
        assert_eq!(state.bond_damage(), Some(&[1.0, 0.0, 0.0][..]));
    }

    #[test]
    fn history_allocates_each_declared_field_once_with_its_length() {
        let state = damaged_state();
        let names: Vec<_> = state.history.declared().map(|f| f.name).collect();
        assert_eq!(names, ["Deviatoric_Plastic_Extension", "Lambda"]);
        assert_eq!(
            state
                .history
                .field("Deviatoric_Plastic_Extension")
                .unwrap()
                .trial()
                .len(),
            3
        );
        assert_eq!(state.history.field("Lambda").unwrap().trial().len(), 2);
        assert!(state.history.field("Back_Extension").is_none());
    }

    #[test]
    fn inside_a_load_step_the_position_is_rounded_from_the_step_start() {
        // Numbers for which (X + u_n) + (u − u_n) and X + u differ in the last bit:
        // 0.028348745054178132 against 0.028348745054178136 (Python floats, IEEE doubles).
        let x = 0.02834747652200631;
        let (start, end) = (8.357651039198697e-07, 1.268532171824923e-06);
        let mut state = State::at_rest(&[[x, 0.0, 0.0]], 0.0, false);
        state.displacement[0][0] = end;
        state.update_current_position(&[[x, 0.0, 0.0]]);
        assert_eq!(state.current_position[0][0], 0.028348745054178136);
        state.step_start = Some(vec![[start, 0.0, 0.0]]);
        state.update_current_position(&[[x, 0.0, 0.0]]);
        assert_eq!(state.current_position[0][0], 0.028348745054178132);
    }
}
