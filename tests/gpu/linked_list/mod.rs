mod gpu;
mod transmission;
mod twins;
