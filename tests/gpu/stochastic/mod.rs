mod gpu;
mod reuse;
mod temporal;
mod transmission;
mod twins;
