mod calibration;
mod compare;
mod goldens;
mod material_forms;
mod robustness;
mod shaders;
mod sweeps;
mod textures;
