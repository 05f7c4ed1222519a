mod context;
mod made;
mod occlusion;
mod shaders;
