//! Appearance variants applied to a finished [`World`] (procedural or imported): lights switched
//! off or dimmed, daylight, smoke haze, repainted materials, and people walking through.
//!
//! The structural parts of [`Variant::FurnitureMoved`], [`Variant::PostersChanged`] and
//! [`Variant::Disaster`] (moved furniture, new posters, debris, missing ceiling tiles) need the
//! building's own generator and are made by `procedural`; [`apply`] adds the light and air of
//! every variant, so an imported model gets those too. People move, so they are not part of the
//! world: a [`Crowd`] gives their triangles for each frame's time.

use crate::trajectory::{rng, stream, uniform};
use crate::world::{Light, MaterialId, Pattern, Variant, World};
use nalgebra::Point3;
use rand::Rng;
use rand::seq::SliceRandom;
use std::collections::{BTreeMap, BTreeSet, HashMap};

mod crowd;
#[cfg(test)]
mod tests;

pub use crowd::{Crowd, Figure};

/// Applies the light, air and colour part of `variant` to `world`, deterministically per `seed`:
///
/// | variant | change |
/// |---|---|
/// | `Normal`, `People`, `FurnitureMoved`, `PostersChanged` | nothing here (see the module docs) |
/// | `SomeLightsOff` | 40–60 % of the lights off, whole circuits of up to 3 neighbouring lights at a time, as switches work |
/// | `Dim` | lights at 30 %, fixtures glow at 40 %, ambient halved, daylight 0.1 (evening) |
/// | `Daylight` | every light off, daylight 1.0, ambient raised to at least 0.4 (morning sun) |
/// | `Disaster` | 75–85 % of the lights off, smoke haze 0.05–0.1 /m, ambient × 0.4, daylight halved |
/// | `TextureSwap` | every material recoloured (a common hue rotation of 90–270° with jitter, greys tinted, lightness changed) and pattern seeds changed; shapes stay |
///
/// A switched-off light also looks off: its fixture's triangles get a dark, non-emissive copy of
/// the fixture material (fixtures often share one material, so the copy is made per material
/// and given only to the triangles nearest a switched-off light).
///
/// An unlit surface (a scan, [`crate::world::Material::unlit`]) ignores lamps and daylight and
/// follows the ambient level alone, so on a scan: `SomeLightsOff` changes nothing (its light is
/// in its photographs; only a file's own lamps switch, lighting what is not unlit); `Dim`
/// halves its brightness; `Daylight` raises it 1.6-fold (ambient 0.4 against the default 0.25;
/// the sensor's shoulder rolls the brightest parts off); `Disaster` brings it to 40 % and adds
/// the haze; `TextureSwap` recolours its flat colour (`shaded` mode) but not its photographs
/// (image textures are used as they are).
pub fn apply(world: &mut World, variant: Variant, seed: u64) {
    let mut r = rng(seed, stream::LIGHTS);
    match variant {
        Variant::Normal | Variant::People | Variant::FurnitureMoved | Variant::PostersChanged => {}
        Variant::SomeLightsOff => {
            let fraction = uniform(&mut r, 0.4, 0.6);
            switch_off(world, fraction, &mut r);
        }
        Variant::Dim => {
            let fixtures: BTreeSet<MaterialId> =
                world.lights.iter().filter_map(|l| l.fixture).collect();
            for l in &mut world.lights {
                l.intensity *= 0.3;
            }
            for m in fixtures {
                if let Some(mat) = world.materials.get_mut(usize::from(m)) {
                    mat.emissive *= 0.4;
                }
            }
            world.atmosphere.ambient *= 0.5;
            world.atmosphere.daylight = world.atmosphere.daylight.min(0.1);
        }
        Variant::Daylight => {
            switch_off(world, 1.0, &mut r);
            world.atmosphere.daylight = 1.0;
            world.atmosphere.ambient = world.atmosphere.ambient.max(0.4);
        }
        Variant::Disaster => {
            let fraction = uniform(&mut r, 0.75, 0.85);
            switch_off(world, fraction, &mut r);
            let a = &mut world.atmosphere;
            a.haze = uniform(&mut r, 0.05, 0.1) as f32;
            a.haze_color = [0.42, 0.40, 0.37];
            a.ambient *= 0.4;
            a.daylight *= 0.5;
        }
        Variant::TextureSwap => swap_textures(world, seed),
    }
}

/// Switches off about `fraction` of the lights that are on: neighbouring lights of one region
/// form circuits of up to three, and whole circuits go off, in random order, as long as that
/// brings the count closer to the target.
fn switch_off(world: &mut World, fraction: f64, r: &mut impl Rng) {
    let on: Vec<usize> = (0..world.lights.len())
        .filter(|&i| world.lights[i].on)
        .collect();
    if on.is_empty() {
        return;
    }
    let target = (fraction * on.len() as f64).round() as usize;
    let mut circuits = circuits(world, &on);
    circuits.shuffle(r);
    let mut off = Vec::new();
    for c in circuits {
        if off.len() + c.len() <= target
            || (off.len() + c.len()).abs_diff(target) < off.len().abs_diff(target)
        {
            off.extend(c);
        }
    }
    for &i in &off {
        world.lights[i].on = false;
    }
    darken_fixtures(world);
}

/// Lights grouped by the region they hang in (or a 5 m cell where none), sorted along the
/// group's longer extent and cut into runs of up to three.
fn circuits(world: &World, lights: &[usize]) -> Vec<Vec<usize>> {
    let mut groups: BTreeMap<[i64; 4], Vec<usize>> = BTreeMap::new();
    for &i in lights {
        let p = world.lights[i].position;
        let below = Point3::new(p.x, p.y, p.z - 0.1);
        let cell = |x: f32| (f64::from(x) / 5.0).floor() as i64;
        let key = match world.regions.iter().position(|reg| reg.contains(&below)) {
            Some(reg) => [reg as i64, 0, 0, 0],
            None => [-1, cell(p.x), cell(p.y), cell(p.z)],
        };
        groups.entry(key).or_default().push(i);
    }
    let mut out = Vec::new();
    for (_, mut g) in groups {
        let span = |f: fn(&Light) -> f32| {
            let v = g.iter().map(|&i| f(&world.lights[i]));
            v.clone().fold(f32::NEG_INFINITY, f32::max) - v.fold(f32::INFINITY, f32::min)
        };
        let along_x = span(|l| l.position.x) >= span(|l| l.position.y);
        g.sort_by(|&a, &b| {
            let (pa, pb) = (world.lights[a].position, world.lights[b].position);
            if along_x {
                pa.x.total_cmp(&pb.x).then(pa.y.total_cmp(&pb.y))
            } else {
                pa.y.total_cmp(&pb.y).then(pa.x.total_cmp(&pb.x))
            }
        });
        out.extend(g.chunks(3).map(<[usize]>::to_vec));
    }
    out
}

/// A 1 m cell of space.
type Cell = (i64, i64, i64);

/// Makes switched-off fixtures look off. A fixture material whose lights are all off is darkened
/// in place (the generator gives each fixture its own material); one shared with lights still on
/// gets a dark, non-emissive copy, given to the triangles whose nearest light of that material
/// (within 1.5 m) is off. A material already darkened (named "… (off)") is left alone, so
/// applying a variant twice changes nothing more.
fn darken_fixtures(world: &mut World) {
    // For each fixture material: is any of its lights on, is any off?
    let mut state: BTreeMap<MaterialId, (bool, bool)> = BTreeMap::new();
    for l in &world.lights {
        if let Some(m) = l.fixture
            && usize::from(m) < world.materials.len()
        {
            let e = state.entry(m).or_insert((false, false));
            e.0 |= l.on;
            e.1 |= !l.on;
        }
    }
    let mut affected: BTreeSet<MaterialId> = BTreeSet::new();
    for (&m, &(any_on, any_off)) in &state {
        let mat = &mut world.materials[usize::from(m)];
        if !any_off || mat.name.ends_with(" (off)") {
            continue;
        }
        if any_on {
            affected.insert(m);
        } else {
            switch_off_look(mat);
        }
    }
    if affected.is_empty() {
        return;
    }
    // Lights of each affected material, binned in 1 m cells.
    let cell = |p: &Point3<f32>| (p.x.floor() as i64, p.y.floor() as i64, p.z.floor() as i64);
    let mut bins: HashMap<(MaterialId, Cell), Vec<usize>> = HashMap::new();
    for (i, l) in world.lights.iter().enumerate() {
        if let Some(m) = l.fixture
            && affected.contains(&m)
        {
            bins.entry((m, cell(&l.position))).or_default().push(i);
        }
    }
    let mut copies: BTreeMap<MaterialId, MaterialId> = BTreeMap::new();
    for &m in &affected {
        if world.materials.len() >= usize::from(MaterialId::MAX) {
            break;
        }
        let mut off = world.materials[usize::from(m)].clone();
        switch_off_look(&mut off);
        copies.insert(m, world.add_material(off));
    }
    for t in &mut world.triangles {
        let Some(&copy) = copies.get(&t.material) else {
            continue;
        };
        let c = Point3::from((t.v[0].coords + t.v[1].coords + t.v[2].coords) / 3.0);
        let (cx, cy, cz) = cell(&c);
        let mut nearest: Option<(f32, bool)> = None;
        for dx in -2..=2 {
            for dy in -2..=2 {
                for dz in -2..=2 {
                    let Some(list) = bins.get(&(t.material, (cx + dx, cy + dy, cz + dz))) else {
                        continue;
                    };
                    for &i in list {
                        let l = &world.lights[i];
                        let d = (l.position - c).norm();
                        if d <= 1.5 && nearest.is_none_or(|(b, _)| d < b) {
                            nearest = Some((d, l.on));
                        }
                    }
                }
            }
        }
        if nearest.is_some_and(|(_, on)| !on) {
            t.material = copy;
        }
    }
}

/// A fixture material as it looks switched off: a grey diffuser, no glow.
fn switch_off_look(m: &mut crate::world::Material) {
    m.name = format!("{} (off)", m.name);
    m.color = m.color.map(|c| c * 0.45);
    m.emissive = 0.0;
}

/// Recolours every material and changes its pattern seed (see [`apply`]).
fn swap_textures(world: &mut World, seed: u64) {
    let mut r = rng(seed, stream::COLOURS);
    let warm = r.random::<bool>();
    let mut uf = |lo: f32, hi: f32| uniform(&mut r, f64::from(lo), f64::from(hi)) as f32;
    let shift = uf(90.0, 270.0);
    for m in &mut world.materials {
        let before = m.color;
        let glowing =
            m.emissive > 0.0 || matches!(m.pattern, Pattern::LightPanel | Pattern::Window);
        m.color = if glowing {
            // Lamps and sky change colour temperature, not hue: a pink ceiling panel would be
            // no building anyone films.
            let tint = if warm {
                [1.0, 0.86, 0.7]
            } else {
                [0.78, 0.88, 1.0]
            };
            std::array::from_fn(|k| before[k] * (0.7 + 0.3 * tint[k]))
        } else {
            let [h, s, v] = rgb_to_hsv(before);
            let h = (h + shift + uf(-15.0, 15.0)).rem_euclid(360.0);
            // Greys have no hue to rotate: give them a faint tint.
            let s = if s < 0.1 {
                uf(0.1, 0.22)
            } else {
                (s * uf(0.8, 1.3)).min(0.9)
            };
            let v = (v * uf(0.8, 1.15)).clamp(0.03, 0.97);
            hsv_to_rgb([h, s, v])
        };
        let moved = m
            .color
            .iter()
            .zip(before)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f32::max);
        if moved < 0.03 {
            // Black, or a tint that happened to land on the old colour: change the lightness.
            let up = before.iter().copied().fold(0.0, f32::max) < 0.5;
            m.color = before.map(|c| if up { (c + 0.12).min(1.0) } else { c * 0.8 });
        }
        m.seed = splitmix(m.seed ^ seed ^ 0x5DEE_CE66_D1CE_5EED);
    }
}

/// Domain randomisation for shape-biased training: every material gets its own random colour
/// (any hue, saturation up to 0.8, lightness 0.08–0.95) and a new pattern seed, independently
/// of the others, unlike [`Variant::TextureSwap`]'s one coherent repaint; lamps and windows
/// only change colour temperature, as in the swap. Geometry, lights and labels stay, so the
/// poses and plane ids of frames rendered from it are those of the building as built.
/// Deterministic per `seed`.
pub fn randomize_materials(world: &mut World, seed: u64) {
    let mut r = rng(seed, stream::COLOURS ^ 0x00ad_0a11);
    let mut uf = |lo: f32, hi: f32| uniform(&mut r, f64::from(lo), f64::from(hi)) as f32;
    for m in &mut world.materials {
        let glowing =
            m.emissive > 0.0 || matches!(m.pattern, Pattern::LightPanel | Pattern::Window);
        m.color = if glowing {
            let warmth = uf(-1.0, 1.0);
            let tint = if warmth > 0.0 {
                [1.0, 1.0 - 0.14 * warmth, 1.0 - 0.3 * warmth]
            } else {
                [1.0 + 0.22 * warmth, 1.0 + 0.12 * warmth, 1.0]
            };
            std::array::from_fn(|k| m.color[k] * tint[k])
        } else {
            hsv_to_rgb([uf(0.0, 360.0), uf(0.0, 0.8), uf(0.08, 0.95)])
        };
        m.seed = splitmix(m.seed ^ seed ^ 0x0D0A_1DAD_5EED_0001);
    }
}

/// Lighting randomisation for shape-biased training, beside [`randomize_materials`]: 0–80 % of
/// the lights switched off (whole circuits, as [`Variant::SomeLightsOff`] does), the others at
/// 50–120 % of their intensity, ambient light at 40–120 % and daylight at 30–120 %. Which lamps
/// are lit is paint, not shape: a network that keys on lit fixtures or on the pools of light
/// under them fails as soon as a circuit trips. No haze, smoke, debris or people: those stay
/// unseen. Deterministic per `seed`.
pub fn randomize_lighting(world: &mut World, seed: u64) {
    let mut r = rng(seed, stream::LIGHTS ^ 0x11_6475);
    let fraction = uniform(&mut r, 0.0, 0.8);
    switch_off(world, fraction, &mut r);
    for l in &mut world.lights {
        l.intensity *= uniform(&mut r, 0.5, 1.2) as f32;
    }
    let a = &mut world.atmosphere;
    a.ambient *= uniform(&mut r, 0.4, 1.2) as f32;
    a.daylight *= uniform(&mut r, 0.3, 1.2) as f32;
}

fn splitmix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// sRGB 0–1 to hue (degrees), saturation, value.
fn rgb_to_hsv([r, g, b]: [f32; 3]) -> [f32; 3] {
    let max = r.max(g).max(b);
    let min = r.min(g).min(b);
    let d = max - min;
    let h = if d <= 0.0 {
        0.0
    } else if max == r {
        60.0 * ((g - b) / d).rem_euclid(6.0)
    } else if max == g {
        60.0 * ((b - r) / d + 2.0)
    } else {
        60.0 * ((r - g) / d + 4.0)
    };
    let s = if max > 0.0 { d / max } else { 0.0 };
    [h, s, max]
}

fn hsv_to_rgb([h, s, v]: [f32; 3]) -> [f32; 3] {
    let c = v * s;
    let hp = h.rem_euclid(360.0) / 60.0;
    let x = c * (1.0 - (hp.rem_euclid(2.0) - 1.0).abs());
    let (r, g, b) = match hp as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = v - c;
    [r + m, g + m, b + m].map(|k| k.clamp(0.0, 1.0))
}
