mod gpu;
mod guards;
mod shaders;
mod transmission;
mod twins;
