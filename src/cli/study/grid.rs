//! The grid of variations: the product of every variation's values, each point of it one
//! variant run, and the up-front check that every key path names a key of the deck.

use std::path::Path;

use peridyn::io::deck::{self, Override, Variation};

/// One variant: a value of every variation.
#[derive(Debug, Clone, PartialEq)]
pub struct Variant {
    /// 0-based position in the grid (the row and the folder `variant_<k>`).
    pub index: usize,
    /// The value of each variation, in the variations' order.
    pub values: Vec<String>,
}

impl Variant {
    /// The deck changes of this variant.
    pub fn overrides(&self, variations: &[Variation]) -> Vec<Override> {
        variations
            .iter()
            .zip(&self.values)
            .flat_map(|(v, value)| v.assignments(value))
            .collect()
    }

    /// The variant's `peridyn run --set` arguments.
    pub fn set_arguments(&self, variations: &[Variation]) -> Vec<String> {
        self.overrides(variations)
            .iter()
            .map(|o| format!("{}={}", o.path.join("."), o.value))
            .collect()
    }
}

/// Every combination of the variations' values; the first variation changes slowest (a
/// study with no variation is one run of the deck as written).
pub fn product(variations: &[Variation]) -> Vec<Variant> {
    let mut combinations: Vec<Vec<String>> = vec![Vec::new()];
    for variation in variations {
        combinations = combinations
            .into_iter()
            .flat_map(|prefix| {
                variation.values.iter().map(move |value| {
                    let mut next = prefix.clone();
                    next.push(value.clone());
                    next
                })
            })
            .collect();
    }
    combinations
        .into_iter()
        .enumerate()
        .map(|(index, values)| Variant { index, values })
        .collect()
}

/// Where a variation was given, for messages.
fn origin(variation: &Variation) -> String {
    match variation.line {
        Some(line) => format!("Study → Vary (line {line})"),
        None => "--vary".to_string(),
    }
}

/// Loads the deck with each value of each variation alone, so that an unknown key path or a
/// value the deck refuses is reported before anything runs, with the deck's file, line and
/// key path. Combinations the deck reader accepts may still fail in the run: those become
/// rows of the table.
pub fn check(deck_path: &Path, variations: &[Variation]) -> Result<(), String> {
    for variation in variations {
        for value in &variation.values {
            deck::load_with(deck_path, &variation.assignments(value)).map_err(|e| {
                format!(
                    "{} \"{}={value}\": {e}",
                    origin(variation),
                    variation.name()
                )
            })?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn variation(path: &str, values: &[&str]) -> Variation {
        Variation {
            path: path.split('.').map(String::from).collect(),
            linked: Vec::new(),
            values: values.iter().map(|v| v.to_string()).collect(),
            line: None,
        }
    }

    #[test]
    fn the_grid_is_the_product_with_the_first_variation_slowest() {
        let variations = [
            variation("Blocks.Bar.Horizon", &["0.1", "0.2"]),
            variation("Solver.Verlet.Safety Factor", &["0.5", "0.7", "0.9"]),
        ];
        let grid = product(&variations);
        assert_eq!(grid.len(), 6);
        assert_eq!(grid[0].values, ["0.1", "0.5"]);
        assert_eq!(grid[2].values, ["0.1", "0.9"]);
        assert_eq!(grid[3].values, ["0.2", "0.5"]);
        assert_eq!(grid[5].index, 5);
        assert_eq!(
            grid[4].set_arguments(&variations),
            ["Blocks.Bar.Horizon=0.2", "Solver.Verlet.Safety Factor=0.7"]
        );
        assert_eq!(product(&[]).len(), 1, "no variation: the deck as written");
    }
}
