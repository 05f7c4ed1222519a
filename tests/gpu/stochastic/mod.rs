mod gpu;
mod reuse;
mod transmission;
mod twins;
