//! Routes over the walk graph: which nodes a walker (or a person of a crowd) visits, in order.

use super::{config, pick_weighted, uniform, uniform_index};
use crate::error::Result;
use crate::world::{Place, PlaceKind, World};
use geom::Pose;
use nalgebra::Vector3;
use rand::Rng;
use std::cmp::Ordering;
use std::collections::{BTreeMap, BinaryHeap, VecDeque};

/// A storey of a building: `(building, storey)`.
pub(crate) type StoreyKey = (u8, u8);

/// The walk graph prepared for routing: positions in `f64`, neighbours with edge lengths, the
/// storey and kind of every node, and connected components.
pub(crate) struct Graph<'w> {
    world: &'w World,
    /// Neighbours of each node with the edge's length (3-D, metres).
    pub adj: Vec<Vec<(usize, f64)>>,
    /// Storey of each node (from its region); `None` where the region index is out of range.
    pub storey: Vec<Option<StoreyKey>>,
    /// Kind of each node's region.
    pub kind: Vec<Option<PlaceKind>>,
    /// Connected component of each node.
    comp: Vec<usize>,
}

/// How a route chooses its way.
pub(crate) struct RouteStyle {
    /// Chance of turning into a room at a node next to one.
    pub room_probability: f64,
    /// Range of distance walked on one storey before heading for the least-visited storey;
    /// `None` never changes storey on purpose (a crowd's people).
    pub storey_dwell_m: Option<[f64; 2]>,
}

impl<'w> Graph<'w> {
    /// Checks the graph and prepares it. Errors: no nodes, no edges, or an edge naming a missing
    /// node.
    pub fn new(world: &'w World) -> Result<Self> {
        let walk = &world.walk;
        if walk.nodes.is_empty() {
            return Err(config(format!(
                "world '{}' has an empty walk graph: nowhere to walk",
                world.name
            )));
        }
        let n = walk.nodes.len();
        let mut adj = vec![Vec::new(); n];
        for (i, &[a, b]) in walk.edges.iter().enumerate() {
            if a >= n || b >= n {
                return Err(config(format!(
                    "walk graph edge {i} joins nodes {a} and {b}, but there are only {n} nodes"
                )));
            }
            if a == b {
                continue;
            }
            let len = (pos_of(world, a) - pos_of(world, b)).norm();
            if !len.is_finite() {
                return Err(config(format!(
                    "walk graph edge {i} has a non-finite length"
                )));
            }
            adj[a].push((b, len));
            adj[b].push((a, len));
        }
        if adj.iter().all(Vec::is_empty) {
            return Err(config(format!(
                "world '{}' has a walk graph without edges: nowhere to walk",
                world.name
            )));
        }
        let place = |i: usize| world.regions.get(walk.nodes[i].region).map(|r| &r.place);
        let storey = (0..n)
            .map(|i| place(i).map(|p| (p.building, p.storey)))
            .collect();
        let kind = (0..n).map(|i| place(i).map(|p| p.kind)).collect();
        let comp = components(&adj);
        Ok(Self {
            world,
            adj,
            storey,
            kind,
            comp,
        })
    }

    /// Position of node `i`, metres.
    pub fn pos(&self, i: usize) -> Vector3<f64> {
        pos_of(self.world, i)
    }

    /// Region index of node `i`.
    pub fn region(&self, i: usize) -> usize {
        self.world.walk.nodes[i].region
    }

    /// The place of node `i`'s region, if the index is valid.
    pub fn place(&self, i: usize) -> Option<&'w Place> {
        self.world
            .regions
            .get(self.world.walk.nodes[i].region)
            .map(|r| &r.place)
    }

    fn is_room(&self, i: usize) -> bool {
        self.kind[i] == Some(PlaceKind::Room)
    }

    /// A random start node with at least one edge; corridors, lobbies and bridges are three times
    /// as likely as rooms and stairwells, as a person filming would start where people walk.
    pub fn random_start(&self, r: &mut impl Rng) -> usize {
        let weights: Vec<f64> = (0..self.adj.len())
            .map(|i| {
                if self.adj[i].is_empty() {
                    0.0
                } else if matches!(
                    self.kind[i],
                    Some(PlaceKind::Corridor | PlaceKind::Lobby | PlaceKind::Bridge)
                ) {
                    3.0
                } else {
                    1.0
                }
            })
            .collect();
        // `new` guarantees an edge, so some weight is positive.
        pick_weighted(r, &weights).unwrap_or(0)
    }

    /// A start node away from a segment's last pose: another storey, or more than 8 m away in
    /// another region; failing those (a small world), more than 3 m away.
    pub fn far_start(
        &self,
        last: &Pose,
        last_place: Option<&Place>,
        r: &mut impl Rng,
    ) -> Result<usize> {
        let here = last.translation;
        let here_storey = last_place.map(|p| (p.building, p.storey));
        let here_f32 = nalgebra::Point3::from(here.cast::<f32>());
        let here_region = self
            .world
            .regions
            .iter()
            .position(|reg| reg.contains(&here_f32));
        let mut strong = Vec::new();
        let mut weak = Vec::new();
        for i in 0..self.adj.len() {
            if self.adj[i].is_empty() {
                continue;
            }
            let p = self.pos(i);
            let dxy = ((p.x - here.x).powi(2) + (p.y - here.y).powi(2)).sqrt();
            let other_storey = here_storey.is_some() && self.storey[i] != here_storey;
            let other_region = Some(self.region(i)) != here_region;
            if other_storey || (dxy > 8.0 && other_region) {
                strong.push(i);
            } else if dxy > 3.0 {
                weak.push(i);
            }
        }
        let pool = if strong.is_empty() { &weak } else { &strong };
        if pool.is_empty() {
            return Err(config(
                "the walk graph is too small for scene cuts: no node lies 3 m from the last one"
                    .into(),
            ));
        }
        Ok(pool[uniform_index(r, pool.len())])
    }

    /// A route from `start` of at least `length_m` metres (or as far as the graph allows): node
    /// indices, consecutive ones joined by an edge.
    pub fn route(
        &self,
        start: usize,
        length_m: f64,
        style: &RouteStyle,
        r: &mut impl Rng,
    ) -> Vec<usize> {
        let mut route = vec![start];
        if self.adj[start].is_empty() {
            return route;
        }
        let mut walked = 0.0;
        let mut prev: Option<usize> = None;
        let mut cur = start;
        let mut visits = vec![0u32; self.adj.len()];
        visits[start] = 1;
        let mut recent: VecDeque<(usize, usize)> = VecDeque::new();
        let mut per_storey: BTreeMap<StoreyKey, f64> = BTreeMap::new();
        for k in self.storey.iter().enumerate().filter_map(|(i, k)| {
            // Only storeys this walker can reach count towards coverage.
            (self.comp[i] == self.comp[start]).then_some(*k).flatten()
        }) {
            per_storey.entry(k).or_insert(0.0);
        }
        let mut on_storey = 0.0;
        let mut dwell_m = dwell(style, r);
        // Distance field to the target storey while heading there.
        let mut goal: Option<(StoreyKey, Vec<f64>)> = None;
        // A route can loop forever on a tiny graph only if edges have zero length; the step cap
        // keeps that finite.
        let max_steps = 1_000_000;
        for _ in 0..max_steps {
            if walked >= length_m {
                break;
            }
            let next = match &goal {
                Some((_, dist)) => self.adj[cur]
                    .iter()
                    .filter(|(n, _)| dist[*n].is_finite())
                    .min_by(|a, b| (a.1 + dist[a.0]).total_cmp(&(b.1 + dist[b.0])))
                    .map(|&(n, _)| n),
                None => None,
            };
            let next = match next {
                Some(n) => n,
                None => {
                    goal = None;
                    self.wander_step(cur, prev, &visits, &recent, style, r)
                }
            };
            let len = self.adj[cur]
                .iter()
                .find(|(n, _)| *n == next)
                .map_or(0.0, |e| e.1);
            walked += len;
            on_storey += len;
            if let Some(k) = self.storey[cur] {
                *per_storey.entry(k).or_insert(0.0) += len;
            }
            if self.storey[next] != self.storey[cur] {
                on_storey = 0.0;
                dwell_m = dwell(style, r);
            }
            recent.push_back((cur, next));
            if recent.len() > 12 {
                recent.pop_front();
            }
            visits[next] = visits[next].saturating_add(1);
            route.push(next);
            prev = Some(cur);
            cur = next;
            if let Some((key, _)) = &goal
                && self.storey[cur] == Some(*key)
            {
                goal = None;
                on_storey = 0.0;
            }
            if goal.is_none() && on_storey > dwell_m {
                goal = self.storey_goal(cur, &per_storey, r);
                on_storey = 0.0;
                dwell_m = dwell(style, r);
            }
        }
        route
    }

    /// One step of the random walk: straight on is likeliest, turning back only at dead ends
    /// (almost), rooms entered with the style's probability, stairs taken only rarely (storey
    /// changes come from the coverage goal), recently walked edges and often visited nodes less
    /// likely.
    fn wander_step(
        &self,
        cur: usize,
        prev: Option<usize>,
        visits: &[u32],
        recent: &VecDeque<(usize, usize)>,
        style: &RouteStyle,
        r: &mut impl Rng,
    ) -> usize {
        let nbrs = &self.adj[cur];
        let in_room = self.is_room(cur);
        let room_nbrs = nbrs
            .iter()
            .filter(|(n, _)| self.is_room(*n) && Some(*n) != prev)
            .count();
        let other_nbrs = nbrs
            .iter()
            .filter(|(n, _)| !self.is_room(*n) && Some(*n) != prev)
            .count();
        // Decide first whether to go into a room, so the probability per door is what the style
        // says however many corridor neighbours there are.
        let into_room = !in_room
            && room_nbrs > 0
            && (other_nbrs == 0 || r.random::<f64>() < style.room_probability);
        let weights: Vec<f64> = nbrs
            .iter()
            .map(|&(n, _)| {
                if !in_room && room_nbrs > 0 && self.is_room(n) != into_room {
                    return 0.0;
                }
                let mut w = match prev {
                    Some(p) if n == p => {
                        if nbrs.len() == 1 {
                            1.0
                        } else {
                            0.02
                        }
                    }
                    Some(p) => {
                        let c = turn_cos(self.pos(p), self.pos(cur), self.pos(n));
                        0.15 + 0.85 * ((1.0 + c) / 2.0).powi(2)
                    }
                    None => 1.0,
                };
                if self.storey[n] != self.storey[cur] {
                    w *= 0.02;
                }
                if recent.contains(&(cur, n)) || recent.contains(&(n, cur)) {
                    w *= 0.25;
                }
                w / (1.0 + 0.2 * f64::from(visits[n].min(10)))
            })
            .collect();
        pick_weighted(r, &weights)
            .map(|i| nbrs[i].0)
            .or_else(|| nbrs.first().map(|e| e.0))
            .unwrap_or(cur)
    }

    /// The least-visited reachable storey other than the current one, with its distance field
    /// (metres along the graph to the nearest of its nodes); ties broken at random.
    fn storey_goal(
        &self,
        cur: usize,
        per_storey: &BTreeMap<StoreyKey, f64>,
        r: &mut impl Rng,
    ) -> Option<(StoreyKey, Vec<f64>)> {
        let here = self.storey[cur];
        let candidates: Vec<(StoreyKey, f64)> = per_storey
            .iter()
            .filter(|(k, _)| Some(**k) != here)
            .map(|(k, d)| (*k, *d))
            .collect();
        let least = candidates
            .iter()
            .map(|c| c.1)
            .min_by(|a, b| a.total_cmp(b))?;
        let ties: Vec<StoreyKey> = candidates
            .iter()
            .filter(|c| c.1 <= least + 1.0)
            .map(|c| c.0)
            .collect();
        let key = ties[uniform_index(r, ties.len())];
        let dist = self.distance_to(|i| self.storey[i] == Some(key));
        dist[cur].is_finite().then_some((key, dist))
    }

    /// Shortest distance along the graph from every node to the nearest node where `target`
    /// holds (Dijkstra from all targets at once).
    fn distance_to(&self, target: impl Fn(usize) -> bool) -> Vec<f64> {
        let n = self.adj.len();
        let mut dist = vec![f64::INFINITY; n];
        let mut heap = BinaryHeap::new();
        for (i, d) in dist.iter_mut().enumerate() {
            if target(i) {
                *d = 0.0;
                heap.push(Entry(0.0, i));
            }
        }
        while let Some(Entry(d, i)) = heap.pop() {
            if d > dist[i] {
                continue;
            }
            for &(j, len) in &self.adj[i] {
                let nd = d + len;
                if nd < dist[j] {
                    dist[j] = nd;
                    heap.push(Entry(nd, j));
                }
            }
        }
        dist
    }
}

/// A heap entry ordered by smallest distance first.
struct Entry(f64, usize);

impl PartialEq for Entry {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        other.0.total_cmp(&self.0).then(other.1.cmp(&self.1))
    }
}

/// Distance to walk on a storey before heading for another.
fn dwell(style: &RouteStyle, r: &mut impl Rng) -> f64 {
    style
        .storey_dwell_m
        .map_or(f64::INFINITY, |[a, b]| uniform(r, a, b))
}

fn pos_of(world: &World, i: usize) -> Vector3<f64> {
    world.walk.nodes[i].p.coords.cast::<f64>()
}

/// Cosine of the turn at `b` going `a → b → c`, in the floor plane; 1 (straight on) where an
/// edge has no horizontal extent.
fn turn_cos(a: Vector3<f64>, b: Vector3<f64>, c: Vector3<f64>) -> f64 {
    let (u, v) = (b - a, c - b);
    let (nu, nv) = (u.xy().norm(), v.xy().norm());
    if nu < 1e-6 || nv < 1e-6 {
        1.0
    } else {
        u.xy().dot(&v.xy()) / (nu * nv)
    }
}

fn components(adj: &[Vec<(usize, f64)>]) -> Vec<usize> {
    let mut comp = vec![usize::MAX; adj.len()];
    let mut next = 0;
    for s in 0..adj.len() {
        if comp[s] != usize::MAX {
            continue;
        }
        comp[s] = next;
        let mut stack = vec![s];
        while let Some(i) = stack.pop() {
            for &(j, _) in &adj[i] {
                if comp[j] == usize::MAX {
                    comp[j] = next;
                    stack.push(j);
                }
            }
        }
        next += 1;
    }
    comp
}
