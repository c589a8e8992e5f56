//! The material painters: one function per procedural [`Pattern`](crate::world::Pattern), which
//! draws a material's texture from its tint and seed (`texture::bake` picks it). They are split
//! by kind, so that no file is long: the repeating surfaces, then one module per wall or ceiling
//! object, each drawn on a `Canvas` of the object's physical size.

mod fixtures;
mod notice_board;
mod poster;
mod repeating;
mod sign;
mod window;

pub(crate) use fixtures::{light_panel, vent};
pub(crate) use notice_board::notice_board;
pub(crate) use poster::poster;
pub(crate) use repeating::{brick, carpet, concrete, fabric, metal, plain, tiles, wood};
pub(crate) use sign::sign;
pub(crate) use window::window;
