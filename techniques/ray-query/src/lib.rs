//! oit-ray-query: ray-traced transparency next to rasterized OIT.
//!
//! One ray per pixel centre through an acceleration structure of the scene's transparent
//! triangles; a ray query collects the K nearest candidate hits without confirming them,
//! composites them front to back, and traces on from the K-th hit until a trace finds fewer
//! than K (every layer composited) or the transmittance falls below a stated ε — the any-hit
//! k-buffer of 3D Gaussian ray tracing (nvpro-samples/vk_gaussian_splatting) with ray queries.
//! Needs `EXPERIMENTAL_RAY_QUERY` (Vulkan; lavapipe from Mesa 24.1: `.ci/lavapipe-ray-query`);
//! refused with the reason elsewhere.
//!
//! - `ray-query:k=1..32,epsilon=0|1e-4|1e-3|1e-2` (defaults 8, 0; see [`Config::DEFAULT`]).

pub mod coverage;
mod technique;

pub use technique::{Config, Epsilon, K, RayQuery};

/// The pass file (includes common.wgsl).
pub const SHADER: &str = include_str!("../shaders/ray_query.wgsl");

/// Every WGSL file of this crate (`shaders/`), by file name.
pub const SHADERS: oit_gpu::shaders::Library = &[("ray_query.wgsl", SHADER)];

/// This crate's `shaders/` folder.
pub const SHADER_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/shaders");

/// This crate as the harness's registry and the shader test see it.
pub const FAMILY: oit_gpu::Family = oit_gpu::Family {
    folder: "ray-query",
    techniques,
    shader_dir: SHADER_DIR,
    shaders: &[SHADERS],
};

use oit_gpu::TechniqueInfo;

/// The registry entries of this crate.
pub fn techniques() -> Vec<TechniqueInfo> {
    vec![TechniqueInfo {
        name: "ray-query",
        description: "ray-traced transparency with ray queries (any-hit k-buffer): per pixel-centre ray, the K nearest candidate hits of each trace composited front to back, traced on from the K-th until none is left; Vulkan adapters with ray queries only",
        params: Config::params(),
        transmission: "exact: composites `C + t ⊙ behind` per channel for every hit, in order",
        build: |spec| Ok(Box::new(RayQuery::from_spec(spec)?)),
    }]
}

#[cfg(test)]
mod tests {
    use super::*;
    use oit_gpu::TechniqueSpec;

    #[test]
    fn registry_is_valid_and_canonical() {
        let registry = techniques();
        for info in &registry {
            info.validate().unwrap();
        }
        let t = TechniqueSpec::build("ray-query", &registry).unwrap();
        assert_eq!(t.spec().to_string(), "ray-query:epsilon=0,k=8");
        let t = TechniqueSpec::build("ray-query:epsilon=1e-3,k=2", &registry).unwrap();
        assert_eq!(t.spec().to_string(), "ray-query:epsilon=1e-3,k=2");
        for bad in ["ray-query:k=0", "ray-query:k=33", "ray-query:epsilon=0.5"] {
            let e = TechniqueSpec::parse(bad, &registry)
                .unwrap_err()
                .to_string();
            assert!(e.contains("k") || e.contains("epsilon"), "{bad}: {e}");
        }
    }
}
