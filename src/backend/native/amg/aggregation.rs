//! Point-wise aggregation on the node graph of a matrix whose unknowns come in groups (a
//! point's free components on the finest level, an aggregate's coarse unknowns below it).
//!
//! Strength of connection between nodes i ≠ j is s_ij = ‖A_ij‖_F / √(‖A_ii‖_F ‖A_jj‖_F), and
//! j is a strong neighbour of i when s_ij ≥ θ · maxₖ s_ik. The usual absolute test s_ij ≥ θ
//! does not fit peridynamics: a point has tens to hundreds of bonds of similar size, so every
//! s_ij is about 1/(family size) and an absolute θ would leave every point alone. Relative to
//! the strongest bond, θ = ½ keeps the neighbours within about twice the nearest spacing for
//! a PMB-like operator (bond stiffness ∝ 1/|ξ|).

use rayon::prelude::*;

use super::super::super::Csr;

/// Nodes per aggregate: `of_node[i]` is the aggregate of node i, aggregates numbered
/// 0..count in order of creation.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Aggregates {
    pub of_node: Vec<usize>,
    pub count: usize,
}

impl Aggregates {
    /// The nodes of every aggregate, each list increasing.
    pub fn members(&self) -> Vec<Vec<usize>> {
        let mut members = vec![Vec::new(); self.count];
        for (node, &aggregate) in self.of_node.iter().enumerate() {
            members[aggregate].push(node);
        }
        members
    }
}

/// The strong neighbours of every node (see the module docs), from the matrix `a` whose
/// unknowns are grouped by `groups` (offsets, as [`crate::backend::native::Preconditioner`]).
pub(super) fn strong_neighbours(a: &Csr, groups: &[usize], threshold: f64) -> Vec<Vec<usize>> {
    let nodes = groups.len() - 1;
    let mut node_of = vec![0; a.nrows];
    for (node, window) in groups.windows(2).enumerate() {
        node_of[window[0]..window[1]].fill(node);
    }
    let norms: Vec<Vec<(usize, f64)>> = (0..nodes)
        .into_par_iter()
        .map(|node| block_row_norms(a, groups, &node_of, node))
        .collect();
    let diagonal: Vec<f64> = norms
        .iter()
        .enumerate()
        .map(|(node, row)| {
            row.iter()
                .find(|&&(j, _)| j == node)
                .map_or(0.0, |&(_, n)| n)
        })
        .collect();
    norms
        .par_iter()
        .enumerate()
        .map(|(i, row)| {
            let strength = |&(j, n): &(usize, f64)| {
                let scale = (diagonal[i] * diagonal[j]).sqrt();
                (j, if scale > 0.0 { n / scale } else { 0.0 })
            };
            let off_diagonal: Vec<(usize, f64)> =
                row.iter().filter(|&&(j, _)| j != i).map(strength).collect();
            let strongest = off_diagonal.iter().fold(0.0f64, |m, &(_, s)| m.max(s));
            off_diagonal
                .into_iter()
                .filter(|&(_, s)| s > 0.0 && s >= threshold * strongest)
                .map(|(j, _)| j)
                .collect()
        })
        .collect()
}

/// ‖A_ij‖_F for every node j coupled to `node`, in increasing j.
fn block_row_norms(a: &Csr, groups: &[usize], node_of: &[usize], node: usize) -> Vec<(usize, f64)> {
    let mut sums: Vec<(usize, f64)> = Vec::new();
    for row in groups[node]..groups[node + 1] {
        let (columns, values) = a.row(row);
        for (&c, &v) in columns.iter().zip(values) {
            let j = node_of[c];
            match sums.binary_search_by_key(&j, |&(k, _)| k) {
                Ok(at) => sums[at].1 += v * v,
                Err(at) => sums.insert(at, (j, v * v)),
            }
        }
    }
    sums.iter_mut().for_each(|(_, s)| *s = s.sqrt());
    sums
}

/// Greedy aggregation in three passes: (1) a node whose strong neighbours are all free roots
/// an aggregate of itself and them; (2) a node still free joins the aggregate of a strong
/// neighbour; (3) what is left forms aggregates of a node and its free strong neighbours
/// (a node without strong neighbours is an aggregate of its own).
pub(super) fn aggregate(strong: &[Vec<usize>]) -> Aggregates {
    const FREE: usize = usize::MAX;
    let mut of_node = vec![FREE; strong.len()];
    let mut count = 0;
    for (node, neighbours) in strong.iter().enumerate() {
        if of_node[node] == FREE
            && !neighbours.is_empty()
            && neighbours.iter().all(|&j| of_node[j] == FREE)
        {
            of_node[node] = count;
            neighbours.iter().for_each(|&j| of_node[j] = count);
            count += 1;
        }
    }
    let after_first_pass = of_node.clone();
    for (node, neighbours) in strong.iter().enumerate() {
        if of_node[node] == FREE {
            if let Some(&j) = neighbours.iter().find(|&&j| after_first_pass[j] != FREE) {
                of_node[node] = after_first_pass[j];
            }
        }
    }
    for (node, neighbours) in strong.iter().enumerate() {
        if of_node[node] == FREE {
            of_node[node] = count;
            for &j in neighbours {
                if of_node[j] == FREE {
                    of_node[j] = count;
                }
            }
            count += 1;
        }
    }
    Aggregates { of_node, count }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_chain_is_cut_into_aggregates_of_three() {
        // Path graph 0–1–2–3–4–5–6: the first pass roots 0 with {1}, refuses 2 (its
        // neighbour 1 is taken), roots 3 with {2, 4}, refuses 5 and roots 6 with {5}.
        let strong: Vec<Vec<usize>> = (0..7usize)
            .map(|i| {
                [i.wrapping_sub(1), i + 1]
                    .into_iter()
                    .filter(|&j| j < 7)
                    .collect()
            })
            .collect();
        let aggregates = aggregate(&strong);
        assert_eq!(aggregates.of_node, vec![0, 0, 1, 1, 1, 2, 2]);
        assert_eq!(aggregates.count, 3);
    }

    #[test]
    fn only_the_strongest_couplings_are_strong() {
        // Three 1-dof nodes: node 0 couples to 1 with −4 and to 2 with −1 (s = 4/5 vs 1/5).
        let a = Csr {
            nrows: 3,
            ncols: 3,
            offsets: vec![0, 3, 5, 7],
            columns: vec![0, 1, 2, 0, 1, 0, 2],
            values: vec![5.0, -4.0, -1.0, -4.0, 5.0, -1.0, 5.0],
        };
        let strong = strong_neighbours(&a, &[0, 1, 2, 3], 0.5);
        assert_eq!(strong[0], vec![1]);
        assert_eq!(strong[1], vec![0]);
        assert_eq!(strong[2], vec![0]);
    }
}
