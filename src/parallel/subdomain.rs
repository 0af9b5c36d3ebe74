//! One rank's part of the model: owned points plus ghosts, as a [`Model`] the ordinary
//! physics and integrator run on.

use super::halo::{layered, new_ghosts};
use super::{Communicator, HaloPlan, Partition};
use crate::damage::{damage_entry, POINT_CRITICAL_STRETCH};
use crate::io::deck::Deck;
use crate::material::material_entry;
use crate::model::{BondList, NodeSets, PointCloud, Reach};
use crate::model::{Model, ModelBlock};

/// Ghost depth the deck's physics needs (see the module docs of [`crate::parallel`]): the
/// widest [`Reach`] that the blocks' material and damage models declare in their registry
/// entries ([`crate::material::MATERIALS`], [`crate::damage::DAMAGE_MODELS`]): 1 when every
/// model's bond decisions and forces read only the two ends of each bond, 2 otherwise
/// (state-based materials read their neighbours' dilatation, which depends on the
/// neighbours' families). A model this build does not run counts as two hops.
pub fn halo_depth(deck: &Deck) -> usize {
    let material_reach = |name: &str| {
        deck.material(name)
            .and_then(|m| material_entry(m.model.deck_name()))
            .map_or(Reach::TwoHop, |entry| entry.declaration.reach)
    };
    let damage_reach = |name: &str| {
        deck.damage_model(name)
            .and_then(|d| damage_entry(d.model.deck_name()))
            .map_or(Reach::TwoHop, |entry| entry.declaration.reach)
    };
    deck.blocks
        .iter()
        .map(|block| {
            let damage = block
                .damage_model
                .as_deref()
                .map_or(Reach::OneHop, damage_reach);
            material_reach(&block.material).max(damage)
        })
        .max()
        .unwrap_or(Reach::OneHop)
        .ghost_layers()
}

/// True when the outermost ghost layer must run the damage models too:
/// * when blocks use different damage models, the interface rule of [`crate::physics`]
///   (`max(d_ij, d_ji)` on bonds between blocks) reads the reverse bonds of the layer-1
///   ghosts' rows, which live in the outer layer's rows;
/// * when a damage model declares the per-point field [`POINT_CRITICAL_STRETCH`]
///   (`Interface Aware`): a bond's limit reads its far end's value, which a point has only as
///   a member of its block (outside the blocks it reads 0, "never breaks").
///
/// With one damage model (or none) everywhere, reading only the bond's own stretch, both
/// directions of a bond are decided alike, and at depth 2 the outer layer only supplies
/// positions, so it stays out of the blocks (less redundant work: its rows are neither damaged
/// nor forced).
pub fn outer_ghosts_need_physics(deck: &Deck) -> bool {
    let first = deck.blocks.first().map(|b| &b.damage_model);
    let reads_far_end = |name: &str| {
        deck.damage_model(name)
            .and_then(|d| damage_entry(d.model.deck_name()))
            .is_some_and(|entry| entry.declaration.fields.contains(&POINT_CRITICAL_STRETCH))
    };
    !deck.blocks.iter().all(|b| Some(&b.damage_model) == first)
        || deck
            .blocks
            .iter()
            .filter_map(|b| b.damage_model.as_deref())
            .any(reads_far_end)
}

/// One rank's share of a distributed run.
///
/// `model` holds the rank's owned points and ghosts in the global run order (so rows keep
/// their bond order and sorted neighbours); each row holds the bonds to other local points,
/// which for owned points (and for layer-1 ghosts at depth 2) is the whole family. Every block
/// lists its owned points and ghosts, so materials and damage models work on ghosts exactly as
/// their owners do. Boundary conditions and node sets list owned points only (ghost values come from
/// the exchange). `model.run_index` is empty: output geometry comes from the global model.
/// At depth 2 the outer ghost layer joins the blocks only when
/// [`outer_ghosts_need_physics`]; otherwise it holds positions only.
#[derive(Debug, Clone)]
pub struct Subdomain {
    /// The partition of all points (the same on every rank).
    pub partition: Partition,
    /// Ghosts and exchanges of this rank.
    pub plan: HaloPlan,
    /// The local model (owned + ghost points).
    pub model: Model,
}

impl Subdomain {
    /// Cuts `global` into `ranks` parts by weighted RCB and builds rank `rank`'s share with
    /// ghosts `depth` bonds deep ([`halo_depth`]); `outer_layer_in_blocks` as
    /// [`outer_ghosts_need_physics`] (ignored at depth 1, where the one layer always joins).
    pub fn new(
        global: &Model,
        ranks: usize,
        rank: usize,
        depth: usize,
        outer_layer_in_blocks: bool,
    ) -> Self {
        let partition = Partition::of_bonds(&global.points.position, &global.bonds, ranks);
        let plan = HaloPlan::build(&global.bonds, &partition, rank, depth);
        let in_blocks = depth == 1 || outer_layer_in_blocks;
        let local_rows = plan.global().iter().map(|&g| {
            let range = global.bonds.range(g as usize);
            (
                &global.bonds.neighbor[range.clone()],
                &global.bonds.reference_length[range],
            )
        });
        let local_of = local_numbering(&plan, global.points.len());
        let bonds = local_bonds(&plan, &local_of, local_rows);
        let model = local_model(global, &plan, in_blocks, bonds, &local_of);
        Self {
            partition,
            plan,
            model,
        }
    }

    /// [`Subdomain::new`] for a global model without families
    /// ([`crate::setup::build_points`]): `rows_of(points)` gives the families of `points`, row
    /// k for `points[k]` ([`crate::setup::family_rows`]). No rank holds more rows than its
    /// owned points' and ghosts' (and, while the points are weighed, a 1/ranks slice), so the
    /// bond memory per rank falls with the rank count. Gives the partition, plan and model of
    /// [`Subdomain::new`] on the global families.
    ///
    /// Collective: every rank calls `rows_of` 3 times (depth 1) or 4 times (depth 2), with
    /// one all-gather of weights and the requests of [`HaloPlan::from_ghosts`] between. `rows_of`
    /// must fail on every rank alike or on none (agree inside it).
    pub fn searched<E>(
        global: &Model,
        comm: &dyn Communicator,
        depth: usize,
        outer_layer_in_blocks: bool,
        mut rows_of: impl FnMut(&[u32]) -> Result<BondList, E>,
    ) -> Result<Self, E> {
        let (n, ranks, rank) = (global.points.len(), comm.size(), comm.rank());
        // Weights `1 + family size`, as Partition::of_bonds: each rank weighs a slice.
        let start = |r: usize| r * n / ranks;
        let slice: Vec<u32> = (start(rank)..start(rank + 1)).map(|p| p as u32).collect();
        let sizes: Vec<f64> = {
            let rows = rows_of(&slice)?;
            (0..slice.len())
                .map(|k| 1.0 + rows.family_size(k) as f64)
                .collect()
        };
        let counts: Vec<usize> = (0..ranks).map(|r| start(r + 1) - start(r)).collect();
        let weights = comm.all_gather(&sizes, &counts);
        let partition = Partition::bisect(&global.points.position, &weights, ranks);
        // The ghost layers, from the rows of the owned points and of layer 1; the outer
        // layer's rows too, since they keep their bonds to other local points.
        let mine = |p: u32| partition.owner[p as usize] as usize == rank;
        let mut mark = vec![0u8; n];
        let owned = &partition.owned[rank];
        let owned_rows = rows_of(owned)?;
        let first = new_ghosts(
            (0..owned.len()).map(|k| owned_rows.family(k)),
            mine,
            &mut mark,
            1,
        );
        let first_rows = rows_of(&first)?;
        let (second, second_rows) = if depth >= 2 {
            let second = new_ghosts(
                (0..first.len()).map(|k| first_rows.family(k)),
                mine,
                &mut mark,
                2,
            );
            let rows = rows_of(&second)?;
            (second, rows)
        } else {
            (Vec::new(), BondList::default())
        };
        let plan = HaloPlan::from_ghosts(&partition, rank, depth, &layered(&first, &second), comm);
        let rows = merged_rows(&plan, owned_rows, [&first_rows, &second_rows]);
        drop((first_rows, second_rows));
        let local_of = local_numbering(&plan, n);
        let bonds = renumbered_in_place(&plan, &local_of, rows);
        let in_blocks = depth == 1 || outer_layer_in_blocks;
        let model = local_model(global, &plan, in_blocks, bonds, &local_of);
        Ok(Self {
            partition,
            plan,
            model,
        })
    }

    /// Local indices of the owned points (increasing).
    pub fn owned(&self) -> &[u32] {
        self.plan.owned()
    }

    /// `true` for every local point that is a ghost.
    pub fn ghost_mask(&self) -> Vec<bool> {
        self.plan.layer().iter().map(|&l| l > 0).collect()
    }
}

/// `local_of[g]`: the local index of global point g, `u32::MAX` for points not on this rank.
fn local_numbering(plan: &HaloPlan, n_global: usize) -> Vec<u32> {
    let mut local_of = vec![u32::MAX; n_global];
    for (l, &g) in plan.global().iter().enumerate() {
        local_of[g as usize] = l as u32;
    }
    local_of
}

/// The local index of neighbour `j` (global) of local point `l`, or `None` when `j` is not
/// on this rank, which only the outermost ghost layer's rows may meet (their bonds to points
/// off this rank are dropped). The local numbering is increasing in the global one, so sorted
/// rows stay sorted.
fn local_neighbor(local_of: &[u32], plan: &HaloPlan, l: usize, j: u32) -> Option<u32> {
    let local = local_of[j as usize];
    if local != u32::MAX {
        return Some(local);
    }
    assert!(
        plan.layer()[l] >= plan.depth() as u8,
        "point {} (layer {}) has a neighbour outside the halo",
        plan.global()[l],
        plan.layer()[l]
    );
    None
}

/// The local bond list from the global rows of the plan's local points, in local order.
fn local_bonds<'a>(
    plan: &HaloPlan,
    local_of: &[u32],
    rows: impl Iterator<Item = (&'a [u32], &'a [f64])>,
) -> BondList {
    let mut bonds = BondList {
        offsets: Vec::with_capacity(plan.global().len() + 1),
        neighbor: Vec::new(),
        reference_length: Vec::new(),
    };
    bonds.offsets.push(0);
    for (l, (neighbors, lengths)) in rows.enumerate() {
        for (&j, &length) in neighbors.iter().zip(lengths) {
            if let Some(local) = local_neighbor(local_of, plan, l, j) {
                bonds.neighbor.push(local);
                bonds.reference_length.push(length);
            }
        }
        bonds.offsets.push(bonds.neighbor.len());
    }
    bonds
}

/// The rows of every local point in local order, from the rows of the owned points and of
/// the two ghost layers (each list in increasing global order, neighbours global). The owned
/// rows' arrays grow in place and every row moves to its local place in one backward pass
/// (an owned row only moves up, past the ghost rows that come before it), so the owned rows,
/// most of the bonds, exist once.
fn merged_rows(plan: &HaloPlan, mut owned: BondList, ghost_layers: [&BondList; 2]) -> BondList {
    let layer = plan.layer();
    // rows_taken[x]: rows of list x (0 owned, 1 and 2 the ghost layers) placed so far.
    let mut rows_taken = [0usize; 3];
    let mut offsets = Vec::with_capacity(layer.len() + 1);
    offsets.push(0);
    for &x in layer {
        let x = usize::from(x);
        let size = match x {
            0 => owned.family_size(rows_taken[0]),
            _ => ghost_layers[x - 1].family_size(rows_taken[x]),
        };
        rows_taken[x] += 1;
        offsets.push(offsets[offsets.len() - 1] + size);
    }
    let total = offsets[layer.len()];
    owned.neighbor.resize(total, 0);
    owned.reference_length.resize(total, 0.0);
    for l in (0..layer.len()).rev() {
        let x = usize::from(layer[l]);
        rows_taken[x] -= 1;
        let (k, to) = (rows_taken[x], offsets[l]);
        if x == 0 {
            let from = owned.offsets[k]..owned.offsets[k + 1];
            owned.neighbor.copy_within(from.clone(), to);
            owned.reference_length.copy_within(from, to);
        } else {
            let rows = ghost_layers[x - 1];
            let from = rows.range(k);
            let to = to..to + from.len();
            owned.neighbor[to.clone()].copy_from_slice(&rows.neighbor[from.clone()]);
            owned.reference_length[to].copy_from_slice(&rows.reference_length[from]);
        }
    }
    owned.offsets = offsets;
    owned
}

/// [`local_bonds`] in place, for `rows` in local order (row l is local point l's, neighbours
/// in global numbering): no second copy of the rows.
fn renumbered_in_place(plan: &HaloPlan, local_of: &[u32], mut rows: BondList) -> BondList {
    let (mut kept, mut start) = (0, 0);
    for l in 0..rows.num_points() {
        // Row l's bonds as searched; `offsets[l]` already holds its compacted start.
        let end = rows.offsets[l + 1];
        // `kept` never passes `b`: every write lands on a bond already read.
        for b in start..end {
            if let Some(local) = local_neighbor(local_of, plan, l, rows.neighbor[b]) {
                rows.neighbor[kept] = local;
                rows.reference_length[kept] = rows.reference_length[b];
                kept += 1;
            }
        }
        rows.offsets[l + 1] = kept;
        start = end;
    }
    rows.neighbor.truncate(kept);
    rows.reference_length.truncate(kept);
    rows
}

/// The model over the plan's local points with their local `bonds`.
fn local_model(
    global: &Model,
    plan: &HaloPlan,
    outer_layer_in_blocks: bool,
    bonds: BondList,
    local_of: &[u32],
) -> Model {
    let local_points = plan.global();
    fn pick<T: Copy>(values: &[T], points: &[u32]) -> Vec<T> {
        points.iter().map(|&g| values[g as usize]).collect()
    }
    let points = PointCloud {
        position: pick(&global.points.position, local_points),
        volume: pick(&global.points.volume, local_points),
        block: pick(&global.points.block, local_points),
        original_id: pick(&global.points.original_id, local_points),
    };
    let horizon = pick(&global.horizon, local_points);
    let owned_local = |points: &[u32]| -> Vec<u32> {
        points
            .iter()
            .map(|&g| local_of[g as usize])
            .filter(|&l| l != u32::MAX && plan.layer()[l as usize] == 0)
            .collect()
    };
    let blocks = global
        .blocks
        .iter()
        .map(|block| ModelBlock {
            info: block.info.clone(),
            deck_block: block.deck_block,
            points: block
                .points
                .iter()
                .map(|&g| local_of[g as usize])
                .filter(|&l| {
                    l != u32::MAX
                        && (outer_layer_in_blocks
                            || usize::from(plan.layer()[l as usize]) < plan.depth())
                })
                .collect(),
        })
        .collect();
    let mut node_sets = NodeSets::default();
    for (name, points) in global.node_sets.iter() {
        node_sets.insert(name, owned_local(points));
    }
    let mut boundary = global.boundary.clone();
    for condition in &mut boundary.conditions {
        condition.points = owned_local(&condition.points);
    }
    Model {
        points,
        horizon,
        blocks,
        node_sets,
        mesh_node_set_names: global.mesh_node_set_names.clone(),
        bonds,
        run_index: Vec::new(),
        boundary,
        min_element_radius: global.min_element_radius,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::deck::{parse_str, DeckFormat};
    use crate::parallel::thread_comm::ThreadComm;

    fn deck(material: &str) -> (tempfile::TempDir, Deck) {
        let dir = tempfile::tempdir().unwrap();
        // Bond-based materials take no shear modulus (ν is fixed).
        let shear = if material == "Elastic" {
            ", Shear Modulus: 0.5"
        } else {
            ""
        };
        let text = format!(
            r#"Peridigm:
  Discretization:
    Type: "PdQuickGrid"
    TensorProduct3DMeshGenerator:
      Type: "PdQuickGrid"
      X Origin: 0.0
      Y Origin: 0.0
      Z Origin: 0.0
      X Length: 10.0
      Y Length: 2.0
      Z Length: 2.0
      Number Points X: 10
      Number Points Y: 2
      Number Points Z: 2
  Materials:
    M: {{Material Model: "{material}", Density: 1.0, Bulk Modulus: 1.0{shear}}}
  Damage Models:
    D: {{Damage Model: "Critical Stretch", Critical Stretch: 0.01}}
  Blocks:
    B: {{Block Names: "block_1", Material: "M", Damage Model: "D", Horizon: 2.1}}
  Boundary Conditions:
    Left Node Set: "1 2 3 4 5 6 7 8 9 10"
    Pull: {{Type: "Prescribed Displacement", Node Set: "Left Node Set", Coordinate: "x", Value: "t"}}
  Solver:
    Final Time: 1.0
    Verlet: {{Fixed dt: 0.1}}
"#
        );
        let deck = parse_str(&text, DeckFormat::Yaml, &dir.path().join("deck.yaml")).unwrap();
        (dir, deck)
    }

    /// `Subdomain::searched` on threads against `Subdomain::new` on the global families.
    fn searched_matches_the_global_build(deck: &Deck, ranks: usize, depth: usize) {
        use crate::discretization::FamilyRule;
        let global = crate::setup::build(deck).unwrap();
        let (points_only, rule) = crate::setup::build_points(deck).unwrap();
        let FamilyRule::Search(rule) = rule else {
            panic!("a QuickGrid box is searched")
        };
        assert_eq!(points_only.bonds.num_bonds(), 0);
        let searched = ThreadComm::run(ranks, |comm| {
            let mut calls = 0;
            let sub = Subdomain::searched(&points_only, comm, depth, false, |points| {
                calls += 1;
                crate::setup::family_rows(deck, &points_only, rule, points)
            })
            .unwrap();
            (sub, calls)
        });
        for (rank, (sub, calls)) in searched.into_iter().enumerate() {
            // Weights, owned rows, layer-1 rows and, at depth 2, layer-2 rows.
            assert_eq!(calls, 2 + depth);
            let expected = Subdomain::new(&global, ranks, rank, depth, false);
            assert_eq!(sub.partition, expected.partition);
            assert_eq!(sub.plan, expected.plan, "rank {rank}");
            assert_eq!(sub.model.bonds, expected.model.bonds, "rank {rank}");
            assert_eq!(sub.model.points, expected.model.points);
            assert_eq!(sub.model.node_sets, expected.model.node_sets);
            let block_points = |m: &Model| -> Vec<Vec<u32>> {
                m.blocks.iter().map(|b| b.points.clone()).collect()
            };
            assert_eq!(block_points(&sub.model), block_points(&expected.model));
        }
    }

    #[test]
    fn searched_families_follow_one_way_bonds() {
        // δ = 1.6 + 0.1·x over x ∈ [0.5, 9.5]: a point's family reaches further than its left
        // neighbours' do, so rows are not symmetric and an owner learns who holds its points
        // only from their requests.
        let (_dir, lps) = deck("Elastic");
        let mut variable = lps.clone();
        for block in &mut variable.blocks {
            block.horizon = crate::io::deck::Horizon::Expression("1.6 + 0.1*x".into());
        }
        let global = crate::setup::build(&variable).unwrap();
        let one_way = (0..global.points.len()).any(|i| {
            global.bonds.family(i).iter().any(|&j| {
                global
                    .bonds
                    .family(j as usize)
                    .binary_search(&(i as u32))
                    .is_err()
            })
        });
        assert!(one_way, "the variable horizon should give one-way bonds");
        for ranks in [2, 3] {
            searched_matches_the_global_build(&variable, ranks, 2);
        }
    }

    #[test]
    fn searched_families_give_the_global_subdomains() {
        // Depth 2 (LPS) and depth 1 (PMB), 2 and 3 ranks; the 10 × 2 × 2 bar with δ = 2.1
        // gives every rank ghosts from both neighbours at 3 ranks.
        let (_dir, lps) = deck("Elastic");
        let (_dir2, pmb) = deck("Elastic Bond Based");
        for ranks in [2, 3] {
            searched_matches_the_global_build(&lps, ranks, 2);
            searched_matches_the_global_build(&pmb, ranks, 1);
        }
    }

    #[test]
    fn lps_ghosts_break_their_bonds_in_the_dilatation_pass_as_their_owners_do() {
        // At depth 2 the outer ghost layer is in no block's list, so the LPS block of a rank
        // does not hold all its neighbours; it still breaks its bonds in its dilatation pass,
        // as on one rank, instead of a separate damage update over its rows.
        let (_dir, deck) = deck("Elastic");
        let global = crate::setup::build(&deck).unwrap();
        let one_rank = crate::setup::build_physics(&deck, &global).unwrap();
        assert!(one_rank.breaks_bonds_in_material_pass(0));
        for rank in 0..3 {
            let sub = Subdomain::new(&global, 3, rank, 2, false);
            let outer = sub.plan.layer().iter().filter(|&&l| l == 2).count();
            assert!(outer > 0, "rank {rank} has an outer ghost layer");
            let physics = crate::setup::build_physics(&deck, &sub.model).unwrap();
            assert!(physics.breaks_bonds_in_material_pass(0), "rank {rank}");
        }
    }

    #[test]
    fn depth_follows_the_materials() {
        assert_eq!(halo_depth(&deck("Elastic Bond Based").1), 1);
        assert_eq!(halo_depth(&deck("Elastic").1), 2);
        // One damage model on every block: the outer layer holds positions only.
        assert!(!outer_ghosts_need_physics(&deck("Elastic").1));
    }

    #[test]
    fn owned_rows_are_whole_families_and_conditions_stay_on_their_owners() {
        let (_dir, deck) = deck("Elastic");
        let global = crate::setup::build(&deck).unwrap();
        let ranks = 3;
        let mut conditioned = 0;
        for rank in 0..ranks {
            let sub = Subdomain::new(&global, ranks, rank, 2, false);
            let local = &sub.model;
            let g = sub.plan.global();
            for (l, &layer) in sub.plan.layer().iter().enumerate() {
                let row: Vec<u32> = local
                    .bonds
                    .family(l)
                    .iter()
                    .map(|&j| g[j as usize])
                    .collect();
                if layer < 2 {
                    assert_eq!(row, global.bonds.family(g[l] as usize));
                }
                let lengths = &local.bonds.reference_length[local.bonds.range(l)];
                if layer < 2 {
                    assert_eq!(
                        lengths,
                        &global.bonds.reference_length[global.bonds.range(g[l] as usize)]
                    );
                }
                assert_eq!(
                    local.points.original_id[l],
                    global.points.original_id[g[l] as usize]
                );
            }
            for condition in &local.boundary.conditions {
                for &p in &condition.points {
                    assert_eq!(sub.plan.layer()[p as usize], 0);
                }
                conditioned += condition.points.len();
            }
        }
        // The ten points of the node set, each on exactly one rank.
        assert_eq!(conditioned, 10);
    }
}
