//! Physics of the bulk material: constitutive models and their shared helpers.

mod elastic_constants;

pub use elastic_constants::{ElasticConstants, ElasticInput, PlanarAssumption};
