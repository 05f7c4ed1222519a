//! Per-tile rasterization, sorting and compositing. All storage lives in a reusable [`Scratch`]
//! sized by the tile, never by the frame. By subject: [`scratch`] (storage and its budget),
//! [`keys`] (depth keys, ties, binning order), [`spans`] (coverage), [`shading`] (fragments),
//! [`tiles`] (a tile, its stored path and bands), [`in_order`] (compositing as fragments
//! arrive), [`sort`] (a pixel's fragments), [`queues`] (render queues' order and depth writes). Each module uses the others through this one.

use std::sync::Mutex;
use std::time::{Duration, Instant};

use rayon::iter::{
    IndexedParallelIterator, IntoParallelIterator, ParallelBridge, ParallelIterator,
};
use rayon::slice::ParallelSliceMut;

use oit_scene::{Material, Shaded, Texels, Texture};

use crate::composite::{composite_coloured_iter, composite_iter, over_step, over_step_coloured};
use crate::setup::{
    HALF, ONE, PixelBox, SetupTriangle, Triangles, same_plane, sample_may_jump, undecided,
    undecided_textured,
};

mod in_order;
mod keys;
mod queues;
mod scratch;
mod shading;
mod sort;
mod spans;
#[cfg(test)]
mod tests;
mod tiles;

pub(crate) use in_order::*;
pub use keys::PRECISION_TIE_ULPS;
pub(crate) use keys::*;
pub(crate) use queues::QueueTable;
use queues::order_by_queue;
pub(crate) use scratch::*;
pub(crate) use shading::Lighting;
use shading::*;
use sort::*;
pub(crate) use spans::*;
pub(crate) use tiles::*;
