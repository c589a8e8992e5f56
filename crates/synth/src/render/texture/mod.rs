//! Baked textures for `textured` mode: photo-like procedural materials of an office building
//! (paint, ceiling and floor tiles, carpet, wood, concrete, brick, posters, notice boards, signs,
//! windows, light panels, vents, brushed metal, fabric) and resampled image textures.
//!
//! [`bake`] turns a [`Material`] into a [`Texture`]: sRGB texels with power-of-two sides, so the
//! renderer wraps texel indices by masking. Content is drawn from [`Material::seed`] and is
//! deterministic: the same material always gives identical texels.
//!
//! # Texture coordinates
//! Texel `(x, y)` (`texels[y * width + x]`) covers `u ∈ [x, x + 1) · repeat_m[0] / width` and
//! `v ∈ [y, y + 1) · repeat_m[1] / height`, wrapping every [`Texture::repeat_m`]. Rows go with
//! `v`: row 0 lies at `v = 0`. Wall-mounted objects (posters, notice boards, signs, windows) are
//! drawn upright for `u` running to the right and `v` running **up** the wall, as wall triangles
//! get when their `v` is the height along the wall: their top edge is the last row. Image
//! textures keep the image's row order (row 0 = the image's top row, which is glTF's `v = 0`; an
//! OBJ importer flips `v`).
//!
//! # Sizes
//! Repeating patterns have a fixed physical repeat in metres ([`Texture::repeat_m`]; tiles repeat
//! every four tiles). Objects that must not repeat are baked for one physical size, given by the
//! `*_SIZE_M` constants (`[width along u, height along v]`); the building generator maps `uv` so
//! that one repeat covers the object: for a point `(x, y)` metres from the object's bottom-left
//! corner, `uv = (x / object_width · SIZE[0], y / object_height · SIZE[1])`. An object of another
//! size takes the same texture, stretched. Wood grain, brick courses and brushed-metal streaks
//! run along `u`; vent slats too.
//!
//! # Tint
//! [`Material::color`] is the dominant colour of every procedural pattern, so `shaded` and
//! `textured` mode agree on a surface's overall colour: paint, tiles, carpet, wood, concrete,
//! bricks, metal and fabric are modulated around it; it is a poster's background, a notice
//! board's cork, a sign's plate, a window's glass (the view is scaled so its mean colour is the
//! tint; frames are aluminium, white or anthracite), a light panel's diffuser and a vent's
//! grille. A sign's content follows the plate's hue: green gives an exit sign (running figure,
//! door, arrow), bright red (e.g. `[0.8, 0.12, 0.1]`) a fire-extinguisher sign, any other colour
//! a room-number plate such as "B2.14" with a name (7 seeds in 10) or an information, toilet or
//! direction sign. [`Pattern::Tiles`] with a light tint (luminance > 0.7) gives speckled
//! acoustic ceiling tiles in a T-bar grid; darker tints give floor tiles with grout. Image
//! textures are used as they are (an importer multiplies a base-colour factor into the image
//! itself).
//!
//! # Layout
//! `noise` (lattice hashes, value, gradient and fractal noise; re-exported here), `color`
//! (colour arithmetic, palettes, the tint and random stream of a material), `canvas` (the
//! drawing surface of objects), `glyphs` (block letters and small print), `painters/` (one
//! painter per procedural pattern, by kind: repeating surfaces, posters, notice boards, signs,
//! windows, ceiling fittings), `resample` (image textures).

mod canvas;
mod color;
mod glyphs;
mod noise;
mod painters;
mod resample;
#[cfg(test)]
mod tests;

pub use noise::{Fbm, GradientNoise, ValueNoise, hash_signed, hash_unit, hash2};

use crate::world::{Material, Pattern};
use color::tint;
use painters::{
    brick, carpet, concrete, fabric, light_panel, metal, notice_board, plain, poster, sign, tiles,
    vent, window, wood,
};
use resample::resample_image;

/// A baked texture: sRGB texels, row-major, width and height powers of two (so the renderer
/// wraps by masking).
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// Texels per row, a power of two.
    pub width: u32,
    /// Rows, a power of two.
    pub height: u32,
    /// sRGB texels, `texels[y * width + x]`; row `y` lies at `v = y · repeat_m[1] / height`.
    pub texels: Vec<[u8; 3]>,
    /// Size of one repeat in uv units: metres along the surface for procedural patterns,
    /// `[1.0, 1.0]` for image textures (whose uv run 0–1).
    pub repeat_m: [f32; 2],
}

impl Texture {
    /// The texel at integer coordinates, wrapping both ways.
    pub fn texel(&self, x: i64, y: i64) -> [u8; 3] {
        let xi = x.rem_euclid(i64::from(self.width.max(1))) as usize;
        let yi = y.rem_euclid(i64::from(self.height.max(1))) as usize;
        self.texels
            .get(yi * self.width as usize + xi)
            .copied()
            .unwrap_or([0; 3])
    }

    /// The nearest texel at `uv` (uv units, wrapping every [`Texture::repeat_m`]).
    pub fn sample_nearest(&self, uv: [f32; 2]) -> [u8; 3] {
        let x = (uv[0] / self.repeat_m[0] * self.width as f32).floor();
        let y = (uv[1] / self.repeat_m[1] * self.height as f32).floor();
        self.texel(x as i64, y as i64)
    }

    /// Mean colour, sRGB 0–1.
    pub fn mean_rgb(&self) -> [f32; 3] {
        let mut sum = [0.0f64; 3];
        for t in &self.texels {
            for (s, &c) in sum.iter_mut().zip(t) {
                *s += f64::from(c);
            }
        }
        let n = self.texels.len().max(1) as f64 * 255.0;
        sum.map(|s| (s / n) as f32)
    }

    /// The texels as an image, row 0 first (for wall objects: upside down; see the module
    /// documentation).
    pub fn to_image(&self) -> image::RgbImage {
        image::RgbImage::from_fn(self.width, self.height, |x, y| {
            image::Rgb(self.texel(i64::from(x), i64::from(y)))
        })
    }
}

/// Physical size of a poster, metres `[width, height]`.
pub const POSTER_SIZE_M: [f32; 2] = [0.6, 0.85];
/// Physical size of a notice board (cork with its frame), metres `[width, height]`.
pub const NOTICE_BOARD_SIZE_M: [f32; 2] = [1.2, 0.9];
/// Physical size of a sign plate (exit sign, information sign, room-number plate), metres
/// `[width, height]`.
pub const SIGN_SIZE_M: [f32; 2] = [0.4, 0.2];
/// Physical size of a window (frame included), metres `[width, height]`.
pub const WINDOW_SIZE_M: [f32; 2] = [1.2, 1.5];
/// Physical size of a square ceiling light panel, metres `[width, height]`; the texture's repeat.
pub const LIGHT_PANEL_SIZE_M: [f32; 2] = [0.6, 0.6];
/// Physical size of a linear light fitting, metres; it takes the light-panel texture stretched
/// (one repeat over the fitting), whose diffuser grid then reads as a louvre.
pub const LIGHT_STRIP_SIZE_M: [f32; 2] = [1.2, 0.3];
/// Physical size of a ceiling vent (a grille in a tile slot), metres `[width, height]`; slats
/// run along `u`.
pub const VENT_SIZE_M: [f32; 2] = [0.6, 0.6];
/// Repeat of painted surfaces ([`Pattern::Plain`]), metres.
pub const PAINT_REPEAT_M: f32 = 2.0;
/// Tiles per repeat along each side for [`Pattern::Tiles`] (repeat = this × tile size).
pub const TILES_PER_REPEAT: u32 = 4;
/// Repeat of carpet: 2 × 2 carpet tiles of 0.5 m laid quarter-turned, metres.
pub const CARPET_REPEAT_M: f32 = 1.0;
/// Repeat of wood, metres `[along the grain (u), across the grain (v)]`.
pub const WOOD_REPEAT_M: [f32; 2] = [1.0, 0.5];
/// Repeat of concrete, metres.
pub const CONCRETE_REPEAT_M: f32 = 2.0;
/// Repeat of brickwork: 4 stretchers (225 mm with joint) by 8 courses (75 mm), metres
/// `[along the courses (u), up the wall (v)]`.
pub const BRICK_REPEAT_M: [f32; 2] = [0.9, 0.6];
/// Repeat of brushed metal, metres; streaks run along `u`.
pub const METAL_REPEAT_M: f32 = 0.5;
/// Repeat of woven fabric, metres.
pub const FABRIC_REPEAT_M: f32 = 0.25;
/// Largest side of a resampled image texture, texels.
pub const MAX_IMAGE_SIDE: u32 = 1024;
/// Largest side of an unlit material's image ([`Material::unlit`]: a scan's texture atlas),
/// texels. An atlas holds a whole room, not one repeating surface: at 1024 a kitchen's atlas
/// would keep texels of 2–3 cm, blurring what a camera a metre away sees. At 4096 its mip levels
/// take about 90 MB; 8192 would take four times that, and 1 GB of scratch while baking.
pub const MAX_ATLAS_SIDE: u32 = 4096;

/// Bakes the material's pattern (procedural or image) into a texture.
///
/// Procedural textures are 64–256 texels a side; see the module documentation for sizes,
/// orientation and how [`Material::color`] tints each pattern.
pub fn bake(material: &Material) -> Texture {
    let m = material;
    match &m.pattern {
        Pattern::Plain => plain(m),
        Pattern::Tiles { size } => tiles(m, *size),
        Pattern::Carpet => carpet(m),
        Pattern::Wood => wood(m),
        Pattern::Concrete => concrete(m),
        Pattern::Brick => brick(m),
        Pattern::Poster => poster(m),
        Pattern::NoticeBoard => notice_board(m),
        Pattern::Sign => sign(m),
        Pattern::Window => window(m),
        Pattern::LightPanel => light_panel(m),
        Pattern::Vent => vent(m),
        Pattern::Metal => metal(m),
        Pattern::Fabric => fabric(m),
        Pattern::Image(img) | Pattern::Atlas { image: img, .. } => {
            let max = if m.unlit {
                MAX_ATLAS_SIDE
            } else {
                MAX_IMAGE_SIDE
            };
            resample_image(img, tint(m), max)
        }
    }
}
