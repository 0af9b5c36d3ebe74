//! How data gets in and out: input decks, Exodus II meshes and results, CSV history.

pub mod deck;
pub mod exodus;
pub mod history;
pub mod output;
pub mod output_folder;
