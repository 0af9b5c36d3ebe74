//! One rank's part of the model: owned points plus ghosts, as a [`Model`] the ordinary
//! physics and integrator run on.

use super::{HaloPlan, Partition};
use crate::io::deck::{DamageKind, Deck, MaterialModel};
use crate::model::{BondList, NodeSets, PointCloud};
use crate::setup::{Model, ModelBlock};

/// Ghost depth the deck's physics needs (see the module docs of [`crate::parallel`]): 1 when
/// every block is bond-based (`Elastic Bond Based`) with no damage or a (time-dependent)
/// critical stretch, whose bond decisions and forces read only the two ends of each bond;
/// 2 otherwise (state-based materials read their neighbours' dilatation, which depends on
/// the neighbours' families).
pub fn halo_depth(deck: &Deck) -> usize {
    let bond_local = deck.blocks.iter().all(|block| {
        let material_ok = deck
            .material(&block.material)
            .is_some_and(|m| matches!(m.model, MaterialModel::ElasticBondBased { .. }));
        let damage_ok = match &block.damage_model {
            None => true,
            Some(name) => deck.damage_model(name).is_some_and(|d| {
                matches!(
                    d.kind,
                    DamageKind::CriticalStretch { .. }
                        | DamageKind::TimeDependentCriticalStretch { .. }
                )
            }),
        };
        material_ok && damage_ok
    });
    if bond_local {
        1
    } else {
        2
    }
}

/// True when the outermost ghost layer must run the damage models too: when blocks use
/// different damage models, the interface rule of [`crate::physics`] (`max(d_ij, d_ji)` on
/// bonds between blocks) reads the reverse bonds of the layer-1 ghosts' rows, which live in
/// the outer layer's rows. With one damage model (or none) everywhere both directions of a
/// bond are decided alike, and at depth 2 the outer layer only supplies positions, so it
/// stays out of the blocks (less redundant work: its rows are neither damaged nor forced).
pub fn outer_ghosts_need_physics(deck: &Deck) -> bool {
    let first = deck.blocks.first().map(|b| &b.damage_model);
    !deck.blocks.iter().all(|b| Some(&b.damage_model) == first)
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
        let model = local_model(global, &plan, depth == 1 || outer_layer_in_blocks);
        Self {
            partition,
            plan,
            model,
        }
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

/// The model over the plan's local points.
fn local_model(global: &Model, plan: &HaloPlan, outer_layer_in_blocks: bool) -> Model {
    let local_points = plan.global();
    let n_global = global.points.len();
    let mut local_of = vec![u32::MAX; n_global];
    for (l, &g) in local_points.iter().enumerate() {
        local_of[g as usize] = l as u32;
    }
    let points = PointCloud {
        position: local_points
            .iter()
            .map(|&g| global.points.position[g as usize])
            .collect(),
        volume: local_points
            .iter()
            .map(|&g| global.points.volume[g as usize])
            .collect(),
        block: local_points
            .iter()
            .map(|&g| global.points.block[g as usize])
            .collect(),
        original_id: local_points
            .iter()
            .map(|&g| global.points.original_id[g as usize])
            .collect(),
    };
    let horizon = local_points
        .iter()
        .map(|&g| global.horizon[g as usize])
        .collect();
    // Rows restricted to local neighbours, in the global bond order; the local numbering is
    // increasing in the global one, so sorted rows stay sorted.
    let mut bonds = BondList {
        offsets: Vec::with_capacity(local_points.len() + 1),
        neighbor: Vec::new(),
        reference_length: Vec::new(),
    };
    bonds.offsets.push(0);
    for (l, &g) in local_points.iter().enumerate() {
        let complete_row = plan.layer()[l] < plan.depth() as u8;
        for b in global.bonds.range(g as usize) {
            let j = global.bonds.neighbor[b];
            let local = local_of[j as usize];
            if local == u32::MAX {
                assert!(
                    !complete_row,
                    "point {g} (layer {}) has a neighbour outside the halo",
                    plan.layer()[l]
                );
                continue;
            }
            bonds.neighbor.push(local);
            bonds
                .reference_length
                .push(global.bonds.reference_length[b]);
        }
        bonds.offsets.push(bonds.neighbor.len());
    }
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
