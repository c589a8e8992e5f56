//! The place classes: their names at each level, and how the three heads' answers are read
//! together ([`joint`]) so that the building, floor and place of an answer agree.

use std::collections::BTreeSet;

use data::native::Label;
use serde::{Deserialize, Serialize};

/// The levels of a place, in head order.
pub const LEVELS: [&str; 3] = ["building", "floor", "corridor"];

/// The class names of each level, sorted.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PlaceClasses {
    /// Building names.
    pub building: Vec<String>,
    /// Floor names, `building/floor`.
    pub floor: Vec<String>,
    /// Places, `building/floor/corridor/direction`.
    pub corridor: Vec<String>,
}

impl PlaceClasses {
    /// The classes that occur in `labels`.
    pub fn of<'a>(labels: impl IntoIterator<Item = &'a Label>) -> PlaceClasses {
        let mut sets: [BTreeSet<String>; 3] = Default::default();
        for label in labels {
            for (set, name) in sets.iter_mut().zip(class_names(label)) {
                set.insert(name);
            }
        }
        let [building, floor, corridor] = sets.map(|s| s.into_iter().collect());
        PlaceClasses {
            building,
            floor,
            corridor,
        }
    }

    /// The class lists in head order.
    pub fn levels(&self) -> [&[String]; 3] {
        [&self.building, &self.floor, &self.corridor]
    }

    /// Number of classes per level.
    pub fn sizes(&self) -> [usize; 3] {
        self.levels().map(<[String]>::len)
    }

    /// For each place class, the indices of its building and floor classes: the hierarchy that
    /// [`joint`] decodes by. `None` when a place's floor or building is not in the lists (a
    /// hand-edited `place.toml`); the levels are then read independently.
    pub fn tree(&self) -> Option<Vec<[usize; 2]>> {
        self.corridor
            .iter()
            .map(|place| {
                let floor = place.rsplitn(3, '/').nth(2)?;
                let building = floor.rsplit_once('/')?.0;
                let f = self
                    .floor
                    .binary_search_by(|n| n.as_str().cmp(floor))
                    .ok()?;
                let b = self
                    .building
                    .binary_search_by(|n| n.as_str().cmp(building))
                    .ok()?;
                Some([b, f])
            })
            .collect()
    }

    /// The class index of `label` at each level; `None` when one of its classes is unknown.
    pub fn indices(&self, label: &Label) -> Option<[usize; 3]> {
        let names = class_names(label);
        let mut out = [0; 3];
        for ((slot, classes), name) in out.iter_mut().zip(self.levels()).zip(&names) {
            *slot = classes.binary_search(name).ok()?;
        }
        Some(out)
    }
}

/// The class name of a label at each level: building, `building/floor`,
/// `building/floor/corridor/direction`.
pub fn class_names(label: &Label) -> [String; 3] {
    let floor = format!("{}/{}", label.building, label.floor);
    let place = format!("{floor}/{}/{}", label.corridor, label.direction);
    [label.building.clone(), floor, place]
}

/// The most likely consistent place of one image from the three heads' probabilities:
/// the place class `c` maximising `p_building(b(c)) · p_floor(f(c)) · p_place(c)` (the heads as a
/// product of experts), with the building and floor it lies in. Each level's probability is the
/// posterior of that product, renormalised over the places, summed over the places in the class.
///
/// Why: each head alone is free to disagree with the others (`B0/F2` from the floor head beside
/// `B0/F1/C2/back` from the place head), and the place head alone throws away what the building
/// and floor heads know. `tree` is [`PlaceClasses::tree`]; `probs` the softmax of each head.
pub fn joint(probs: [&[f32]; 3], tree: &[[usize; 2]]) -> [(usize, f32); 3] {
    decode(&place_posterior(probs, tree), tree)
}

/// The posterior over place classes of the heads' product (see [`joint`]), summing to 1.
pub fn place_posterior(probs: [&[f32]; 3], tree: &[[usize; 2]]) -> Vec<f32> {
    let [building, floor, place] = probs;
    // Scores in log space, shifted by their maximum so that the exponentials cannot underflow
    // all together.
    let log = |p: f32| p.max(f32::MIN_POSITIVE).ln();
    let scores: Vec<f32> = tree
        .iter()
        .zip(place)
        .map(|(&[b, f], &p)| log(building[b]) + log(floor[f]) + log(p))
        .collect();
    let top = scores.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    let mut weights: Vec<f32> = scores.iter().map(|s| (s - top).exp()).collect();
    let total: f32 = weights.iter().sum();
    weights.iter_mut().for_each(|w| *w /= total);
    weights
}

/// The most likely place of a `posterior` over place classes, with its building and floor and
/// each one's probability (the posterior mass of the places in it).
pub fn decode(posterior: &[f32], tree: &[[usize; 2]]) -> [(usize, f32); 3] {
    let best = argmax(posterior).0;
    let [b, f] = tree.get(best).copied().unwrap_or_default();
    let mass = |keep: &dyn Fn(&[usize; 2]) -> bool| {
        tree.iter()
            .zip(posterior)
            .filter(|(t, _)| keep(t))
            .map(|(_, w)| w)
            .sum::<f32>()
    };
    [
        (b, mass(&|t| t[0] == b)),
        (f, mass(&|t| t[1] == f)),
        (best, posterior.get(best).copied().unwrap_or(0.0)),
    ]
}

/// The index of the largest value and the value (the first of equals).
pub(super) fn argmax(values: &[f32]) -> (usize, f32) {
    values.iter().enumerate().fold(
        (0, f32::NEG_INFINITY),
        |acc, (i, &v)| if v > acc.1 { (i, v) } else { acc },
    )
}
