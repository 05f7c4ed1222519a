mod auto;
mod gpu;
mod transmission;
mod twins;
