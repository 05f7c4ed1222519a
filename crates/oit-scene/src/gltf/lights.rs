//! A glTF asset's lighting: each material's reflectance and the `KHR_lights_punctual` lights
//! (or the default rig) in world space.

use super::*;

impl Asset {
    /// The lighting parameters of material `m`: `None` when it is unlit (`KHR_materials_unlit`
    /// or [`GltfLighting::Unlit`]), else its metallic and roughness factors (the
    /// metallic-roughness texture is not read: `notes::unread_properties` lists it).
    pub(super) fn reflectance(
        &self,
        m: &gltf::Material,
        mp: &str,
        lighting: GltfLighting,
    ) -> Result<Option<Reflectance>> {
        let GltfLighting::PerPixel(specular) = lighting else {
            return Ok(None);
        };
        if m.unlit() {
            return Ok(None);
        }
        let pbr = m.pbr_metallic_roughness();
        let factor = |v: f32, name: &str| -> Result<f32> {
            if !v.is_finite() || !(0.0..=1.0).contains(&v) {
                return Err(self.cx.bad(
                    format!("{mp}/pbrMetallicRoughness/{name}"),
                    name,
                    v,
                    "a finite value in [0, 1]",
                ));
            }
            Ok(v)
        };
        let metallic = factor(pbr.metallic_factor(), "metallicFactor")?;
        let roughness = factor(pbr.roughness_factor(), "roughnessFactor")?;
        Ok(Some(Reflectance {
            metallic,
            roughness,
            specular: specular.unwrap_or(Specular::Faded),
        }))
    }

    /// Appends the `KHR_lights_punctual` lights the node instances place (through
    /// `placement.transform`) to `scene.lights`, at most [`crate::MAX_LIGHTS`] in all.
    pub(crate) fn add_lights(
        &self,
        nodes: &Nodes,
        placement: &Placement,
        scene: &mut Scene,
    ) -> Result<()> {
        let outer = Mat4::from(placement.transform);
        for &(node, light, world) in &nodes.lights {
            let Some(l) = self.doc.lights().and_then(|mut ls| ls.nth(light)) else {
                continue;
            };
            let lp = format!("/extensions/KHR_lights_punctual/lights/{light}");
            let w = outer * world;
            let color = l.color();
            let intensity = l.intensity();
            if !intensity.is_finite() || intensity < 0.0 {
                return Err(self.cx.bad(
                    format!("{lp}/intensity"),
                    "light intensity",
                    intensity,
                    "a finite value >= 0",
                ));
            }
            for (k, c) in color.iter().enumerate() {
                if !c.is_finite() || *c < 0.0 {
                    return Err(self.cx.bad(
                        format!("{lp}/color/{k}"),
                        "light colour component",
                        c,
                        "finite values >= 0",
                    ));
                }
            }
            let range = l.range().unwrap_or(0.0);
            if !range.is_finite() || range < 0.0 || (l.range().is_some() && range == 0.0) {
                return Err(self.cx.bad(
                    format!("{lp}/range"),
                    "light range",
                    range,
                    "a finite value > 0 (absent: infinite)",
                ));
            }
            let position = w.transform_point3(Vec3::ZERO);
            let direction = w.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
            if !position.is_finite() || direction == Vec3::ZERO || !direction.is_finite() {
                return Err(self.cx.err(
                    placement.derived_path(node),
                    Problem::DerivedNonFinite {
                        what: format!("position or direction of the light of /nodes/{node}"),
                    },
                ));
            }
            let (kind, cone_scale, cone_offset) = match l.kind() {
                gltf::khr_lights_punctual::Kind::Directional => (LightKind::Directional, 0.0, 1.0),
                gltf::khr_lights_punctual::Kind::Point => (LightKind::Point, 0.0, 1.0),
                gltf::khr_lights_punctual::Kind::Spot {
                    inner_cone_angle,
                    outer_cone_angle,
                } => {
                    let quarter = std::f32::consts::FRAC_PI_2;
                    let ordered = (0.0..quarter).contains(&inner_cone_angle)
                        && inner_cone_angle < outer_cone_angle
                        && outer_cone_angle <= quarter;
                    if !ordered {
                        return Err(self.cx.bad(
                            format!("{lp}/spot"),
                            "spot cone angles (inner, outer)",
                            format!("({inner_cone_angle}, {outer_cone_angle})"),
                            "0 <= innerConeAngle < outerConeAngle <= π/2",
                        ));
                    }
                    let (scale, offset) = PunctualLight::cone(inner_cone_angle, outer_cone_angle);
                    (LightKind::Spot, scale, offset)
                }
            };
            if scene.lights.lights.len() >= crate::MAX_LIGHTS {
                return Err(self.cx.bad(
                    format!("{lp} (placed by /nodes/{node})"),
                    "lights in the scene",
                    scene.lights.lights.len() + 1,
                    &format!(
                        "at most {} punctual lights per scene (one fixed-size GPU uniform array)",
                        crate::MAX_LIGHTS
                    ),
                ));
            }
            scene.lights.lights.push(PunctualLight {
                kind,
                position: position.to_array(),
                direction: direction.to_array(),
                radiance: color.map(|c| c * intensity),
                range,
                cone_scale,
                cone_offset,
            });
            scene.lights.origin = "KHR_lights_punctual".into();
        }
        Ok(())
    }
}
