mod gpu;
mod shaders;
