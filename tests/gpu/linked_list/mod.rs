mod auto;
pub(crate) use auto::reference_and_key_ties;
mod gpu;
mod hybrid;
mod slab;
mod transmission;
mod twins;
