mod context;
mod shaders;
