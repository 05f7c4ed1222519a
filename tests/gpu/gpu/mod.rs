mod context;
mod occlusion;
mod shaders;
