//! `Contact` list: short-range repulsive forces between points that are not bonded.

use super::error::DeckError;
use super::reader::{Ctx, Field};

/// The `Contact` list.
#[derive(Debug, Clone, PartialEq)]
pub struct Contact {
    /// `Search Radius` (required, > 0): radius of the proximity search for contact pairs.
    pub search_radius: f64,
    /// `Search Frequency` (required, ≥ 1): time steps between proximity searches.
    pub search_frequency: u64,
    /// `Verbose` — default false.
    pub verbose: bool,
    /// `Models` — named contact models, file order.
    pub models: Vec<ContactModel>,
    /// `Interactions` — which blocks touch which, file order.
    pub interactions: Vec<ContactInteraction>,
}

/// One named entry of `Contact → Models`.
#[derive(Debug, Clone, PartialEq)]
pub struct ContactModel {
    /// The name of the list; interactions refer to it with `Contact Model`.
    pub name: String,
    /// `Contact Radius` r_c (required, > 0): pairs closer than this repel.
    pub contact_radius: f64,
    /// `Spring Constant` k_s (required, > 0).
    pub spring_constant: f64,
    /// `Contact Model` and the friction coefficient.
    pub friction: Friction,
}

/// `Contact Model` and its `Friction Coefficient`.
#[derive(Debug, Clone, PartialEq)]
pub enum Friction {
    /// `"Short Range Force"`: constant `Friction Coefficient` μ_f ≥ 0 (default 0).
    Constant(f64),
    /// `"Time Dependent Short Range Force"`: `Friction Coefficient` is an expression in `t`.
    TimeDependent(String),
}

/// One entry of `Contact → Interactions`.
#[derive(Debug, Clone, PartialEq)]
pub enum ContactInteraction {
    /// `General Contact: {Contact Model: ...}` — every pair of different blocks.
    General {
        /// `Contact Model` — name of an entry of `Models`.
        model: String,
    },
    /// `Self Contact: {Contact Model: ...}` — every block with itself.
    SelfContact {
        /// `Contact Model` — name of an entry of `Models`.
        model: String,
    },
    /// Any other name: one pair of blocks.
    Pair {
        /// The name of the list.
        name: String,
        /// `First Block` (required) — mesh block name.
        first_block: String,
        /// `Second Block` (required) — mesh block name.
        second_block: String,
        /// `Contact Model` (required) — name of an entry of `Models`.
        model: String,
    },
}

impl ContactInteraction {
    /// The contact model the interaction uses.
    pub fn model(&self) -> &str {
        match self {
            ContactInteraction::General { model }
            | ContactInteraction::SelfContact { model }
            | ContactInteraction::Pair { model, .. } => model,
        }
    }
}

pub(crate) fn read(ctx: &mut Ctx, field: &Field) -> Result<Contact, DeckError> {
    let mut list = field.list(ctx)?;
    list.expect(&["Search Radius", "Search Frequency"]);
    let search_radius = list.positive_req(ctx, "Search Radius")?;
    let search_frequency = list.int_req(ctx, "Search Frequency", 1)? as u64;
    let verbose = list.flag_without_effect(
        ctx,
        "Verbose",
        false,
        true,
        "peridyn prints no extra contact output (the run log reports the searches)",
    )?;
    let mut models = Vec::new();
    if let Some(mut m) = list.list_opt(ctx, "Models")? {
        for f in m.all() {
            let mut model = f.list(ctx)?;
            let kind = model
                .require(
                    ctx,
                    "Contact Model",
                    "\"Short Range Force\" or \"Time Dependent Short Range Force\"",
                )?
                .choice(
                    ctx,
                    &["Short Range Force", "Time Dependent Short Range Force"],
                )?;
            let contact_radius = model.positive_req(ctx, "Contact Radius")?;
            let spring_constant = model.positive_req(ctx, "Spring Constant")?;
            let friction = if kind == "Short Range Force" {
                Friction::Constant(
                    model
                        .non_negative_opt(ctx, "Friction Coefficient")?
                        .unwrap_or(0.0),
                )
            } else {
                Friction::TimeDependent(
                    model
                        .require(ctx, "Friction Coefficient", "an expression in t")?
                        .name(ctx)?,
                )
            };
            model.finish(
                ctx,
                &[(
                    "Horizon",
                    "the contact force uses the horizon of each point's block",
                )],
            )?;
            models.push(ContactModel {
                name: f.key().to_string(),
                contact_radius,
                spring_constant,
                friction,
            });
        }
    }
    let mut interactions = Vec::new();
    if let Some(mut i) = list.list_opt(ctx, "Interactions")? {
        for f in i.all() {
            let mut entry = f.list(ctx)?;
            let interaction = match f.key() {
                "General Contact" | "Self Contact" => {
                    let model = entry.name_req(ctx, "Contact Model")?;
                    if f.key() == "General Contact" {
                        ContactInteraction::General { model }
                    } else {
                        ContactInteraction::SelfContact { model }
                    }
                }
                name => ContactInteraction::Pair {
                    name: name.to_string(),
                    first_block: entry.name_req(ctx, "First Block")?,
                    second_block: entry.name_req(ctx, "Second Block")?,
                    model: entry.name_req(ctx, "Contact Model")?,
                },
            };
            let model_line = entry
                .get("Contact Model")
                .map(|m| (m.line(), m.path.clone()));
            entry.finish(ctx, &[])?;
            if !models
                .iter()
                .any(|m: &ContactModel| m.name == interaction.model())
            {
                let (line, path) = model_line.expect("Contact Model was required above");
                let known = models.iter().map(|m| m.name.as_str());
                let hint = match super::reader::suggest(interaction.model(), known) {
                    Some(s) => format!("; did you mean \"{s}\"?"),
                    None => "; define it under `Contact → Models`".to_string(),
                };
                return Err(ctx.error(
                    Some(line),
                    &path,
                    format!("no contact model named \"{}\"{hint}", interaction.model()),
                ));
            }
            interactions.push(interaction);
        }
    }
    list.finish(ctx, &[])?;
    Ok(Contact {
        search_radius,
        search_frequency,
        verbose,
        models,
        interactions,
    })
}
