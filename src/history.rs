//! Fields that a step may change and then accept or abandon ([`Staged`]), the materials'
//! history made of them ([`History`]), and the declarations of model fields
//! ([`FieldDeclaration`]). The run's [`crate::state::State`] holds them; the materials read
//! and write them (through [`crate::model::CurrentView`] and
//! [`crate::material::Material::update_history`]) without depending on the rest of the state.

/// What a field of a model is attached to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FieldCarrier {
    /// One value per point.
    Point,
    /// One value per directed bond, indexed like the bond list.
    Bond,
}

impl FieldCarrier {
    /// The word `peridyn check` prints for the carrier.
    pub fn name(self) -> &'static str {
        match self {
            FieldCarrier::Point => "point",
            FieldCarrier::Bond => "bond",
        }
    }
}

/// A field a model keeps between force evaluations.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FieldDeclaration {
    /// The field's name (Peridigm's, where it has one), e.g. `Weighted_Volume`.
    pub name: &'static str,
    /// Point or bond field.
    pub carrier: FieldCarrier,
    /// Bytes of one value (8 for `f64`, 4 for `f32`).
    pub bytes_per_value: u64,
    /// True when the field evolves with the deformation and is staged: a trial value during a
    /// load step, committed on acceptance and restored on rejection (bond damage). False for
    /// fields fixed by the reference configuration or recomputed from the current one in every
    /// evaluation (LPS weighted volume and dilatation).
    pub staged: bool,
}

/// A field that a step may change and then accept or abandon.
///
/// `trial` is what force evaluations read and write. While a committed copy is kept
/// ([`Staged::keep_committed`]), [`Staged::restore`] puts the committed values back and
/// [`Staged::commit`] accepts the trial values; without a copy both do nothing, the trial
/// values being the accepted ones (explicit steps accept every step).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Staged<T> {
    trial: Vec<T>,
    committed: Option<Vec<T>>,
}

impl<T: Copy> Staged<T> {
    /// A field of `len` entries equal to `value`, without a committed copy.
    pub fn filled(len: usize, value: T) -> Self {
        Self {
            trial: vec![value; len],
            committed: None,
        }
    }

    /// The trial values (what the next force evaluation reads).
    pub fn trial(&self) -> &[T] {
        &self.trial
    }

    /// The trial values, for the force evaluation that updates them.
    pub fn trial_mut(&mut self) -> &mut [T] {
        &mut self.trial
    }

    /// The accepted values: the committed copy when one is kept, else the trial values.
    pub fn committed(&self) -> &[T] {
        self.committed.as_deref().unwrap_or(&self.trial)
    }

    /// From now on keep a committed copy, equal to the trial values now.
    pub fn keep_committed(&mut self) {
        match &mut self.committed {
            Some(committed) => committed.copy_from_slice(&self.trial),
            None => self.committed = Some(self.trial.clone()),
        }
    }

    /// Drops the committed copy (the trial values are accepted as they are).
    pub fn drop_committed(&mut self) {
        self.committed = None;
    }

    /// Accepts the trial values.
    pub fn commit(&mut self) {
        if let Some(committed) = &mut self.committed {
            committed.copy_from_slice(&self.trial);
        }
    }

    /// The committed values (read) and the trial values (written) at once, for an update that
    /// computes the trial values from the committed ones. Keeps a committed copy from now on
    /// if none was kept (equal to the trial values now).
    pub fn committed_and_trial(&mut self) -> (&[T], &mut [T]) {
        if self.committed.is_none() {
            self.committed = Some(self.trial.clone());
        }
        let committed = self.committed.as_deref().unwrap_or_default();
        (committed, &mut self.trial)
    }

    /// Sets the accepted values: the trial values and, when one is kept, the committed copy
    /// (a run resumed from a restart file). `values` has the field's length.
    pub fn set_accepted(&mut self, values: &[T]) {
        self.trial.copy_from_slice(values);
        if let Some(committed) = &mut self.committed {
            committed.copy_from_slice(values);
        }
    }

    /// Abandons the trial values: they become the committed ones again.
    pub fn restore(&mut self) {
        if let Some(committed) = &self.committed {
            self.trial.copy_from_slice(committed);
        }
    }
}

/// Material history: the staged fields the materials of a run declare
/// ([`FieldDeclaration::staged`], e.g. a plastic extension per bond), each allocated once
/// (zero-initialised) however many blocks declare it; a block writes only its own entries.
/// A field holds [`FieldDeclaration::bytes_per_value`]` / 8` numbers per point or bond (9 for
/// a 3×3 tensor, row-major). Bond damage, which damage models declare, is
/// [`State::bond_damage`].
///
/// History always keeps its committed copy, explicit runs included: a material's update
/// reads the committed values and writes the trial ones
/// ([`Staged::committed_and_trial`]), so an extra force evaluation within a step (an output,
/// a probe) never advances the history twice.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct History {
    fields: Vec<(FieldDeclaration, Staged<f64>)>,
    /// Δt of the step the trial values advance over (s); see [`History::step_duration`].
    step_duration: f64,
    /// The point temperatures, when the deck has thermal conditions (see [`Thermal`]).
    thermal: Option<Thermal>,
}

/// The temperature of every point, allocated only when a deck has a `Prescribed Temperature`
/// or `Initial Temperature` condition. The conditions set it at the start of every step (a
/// function of time, so it is not staged: a rejected step sets it again); the materials and
/// damage models read it through [`History::thermal`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Thermal {
    /// Temperature T (Peridigm's `Temperature`; degrees).
    pub temperature: Vec<f64>,
    /// ΔT, the change of T since t = 0 (Peridigm's `Temperature_Change`): what drives the
    /// thermal strain.
    pub change: Vec<f64>,
    /// α_i ΔT_i, the free thermal strain of each point, α the `Thermal Expansion Coefficient`
    /// of the point's material (0 for materials without one); the physics fills it before
    /// every force evaluation.
    pub strain: Vec<f64>,
    /// ΔT as the materials' history saw it, staged with that history: the trial value is ΔT
    /// of the last force evaluation, the committed one ΔT of the last accepted evaluation (the
    /// start of the step). Models that integrate the thermal strain in increments read the
    /// increment `change − committed` (`Elastic Correspondence`).
    pub evaluated: Staged<f64>,
}

impl Thermal {
    /// T = ΔT = 0 at `points` points.
    pub fn at_rest(points: usize) -> Self {
        Self {
            temperature: vec![0.0; points],
            change: vec![0.0; points],
            strain: vec![0.0; points],
            evaluated: {
                let mut evaluated = Staged::filled(points, 0.0);
                evaluated.keep_committed();
                evaluated
            },
        }
    }
}

impl History {
    /// Allocates every staged field of `declared` (fields that are not staged are the
    /// models' own scratch; a name declared twice is allocated once, as first declared) for
    /// `points` points and `bonds` directed bonds.
    pub fn allocate<'a>(
        declared: impl IntoIterator<Item = &'a FieldDeclaration>,
        points: usize,
        bonds: usize,
    ) -> Self {
        let mut fields: Vec<(FieldDeclaration, Staged<f64>)> = Vec::new();
        for field in declared.into_iter().filter(|f| f.staged) {
            if fields.iter().any(|(f, _)| f.name == field.name) {
                continue;
            }
            let count = match field.carrier {
                FieldCarrier::Point => points,
                FieldCarrier::Bond => bonds,
            };
            let numbers_per_value = (field.bytes_per_value / 8).max(1) as usize;
            let mut values = Staged::filled(count * numbers_per_value, 0.0);
            values.keep_committed();
            fields.push((*field, values));
        }
        Self {
            fields,
            step_duration: 0.0,
            thermal: None,
        }
    }

    /// The field called `name`, if a model declared it.
    pub fn field(&self, name: &str) -> Option<&Staged<f64>> {
        self.fields
            .iter()
            .find(|(f, _)| f.name == name)
            .map(|(_, values)| values)
    }

    /// The field called `name`, for the force evaluation that updates it.
    pub fn field_mut(&mut self, name: &str) -> Option<&mut Staged<f64>> {
        self.fields
            .iter_mut()
            .find(|(f, _)| f.name == name)
            .map(|(_, values)| values)
    }

    /// Δt of the step whose trial values the force evaluations compute (s): the load step of
    /// an implicit solver, the time step of an explicit one. Rate-dependent models read it
    /// (`Viscoplastic Needleman Correspondence`); the time integrators set it at the start of
    /// every step ([`History::set_step_duration`]). 0 until then: no time passes, so a
    /// rate-dependent model responds elastically (the force evaluation at rest before the
    /// first step).
    pub fn step_duration(&self) -> f64 {
        self.step_duration
    }

    /// Sets Δt of the step about to be solved (see [`History::step_duration`]).
    pub fn set_step_duration(&mut self, duration: f64) {
        self.step_duration = duration;
    }

    /// The point temperatures, when the deck has thermal conditions.
    pub fn thermal(&self) -> Option<&Thermal> {
        self.thermal.as_ref()
    }

    /// The point temperatures, for the conditions that set them and the physics that derives
    /// the thermal strain.
    pub fn thermal_mut(&mut self) -> Option<&mut Thermal> {
        self.thermal.as_mut()
    }

    /// Allocates the point temperatures (T = ΔT = 0) for `points` points (a deck with thermal
    /// conditions).
    pub fn with_thermal(mut self, points: usize) -> Self {
        self.thermal = Some(Thermal::at_rest(points));
        self
    }

    /// Every field with its declaration, in declaration order (restart files).
    pub fn fields(&self) -> impl Iterator<Item = (&FieldDeclaration, &Staged<f64>)> {
        self.fields.iter().map(|(f, values)| (f, values))
    }

    /// The declared fields, in declaration order.
    pub fn declared(&self) -> impl Iterator<Item = &FieldDeclaration> {
        self.fields.iter().map(|(f, _)| f)
    }

    /// The history of a run without history fields.
    pub const fn empty() -> Self {
        Self {
            fields: Vec::new(),
            step_duration: 0.0,
            thermal: None,
        }
    }

    /// Applies `action` to every field (tests that stage history by hand).
    #[cfg(test)]
    pub(crate) fn each_for_tests(&mut self, action: impl Fn(&mut Staged<f64>)) {
        self.fields
            .iter_mut()
            .for_each(|(_, values)| action(values));
    }

    /// Applies `action` to every field and to the temperature change the history saw
    /// ([`Thermal::evaluated`]) (the state's commit, restore and copies).
    pub(crate) fn each(&mut self, action: fn(&mut Staged<f64>)) {
        self.fields
            .iter_mut()
            .for_each(|(_, values)| action(values));
        if let Some(thermal) = &mut self.thermal {
            action(&mut thermal.evaluated);
        }
    }
}

/// The history of a run whose models declare no history field.
pub static NO_HISTORY: History = History::empty();
