#[test]
fn probe() {
    for f in [
        "AlphaBlendModeTest/AlphaBlendModeTest.glb",
        "GlassVaseFlowers/GlassVaseFlowers.glb",
    ] {
        let p =
            std::path::PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets/")).join(f);
        let t = std::time::Instant::now();
        let s = oit_scene::load(&p).unwrap();
        println!("{} {:?} {}", s.name, t.elapsed(), s.description);
        for m in &s.materials {
            println!("  {:?}", m);
        }
        for t in &s.textures {
            println!(
                "  tex {} {}x{} {:?} {:?} {:?}",
                t.name, t.width, t.height, t.wrap_u, t.wrap_v, t.texels[0]
            );
        }
        for d in &s.draws {
            println!(
                "  draw {} mat {} tris {}",
                d.name,
                d.material,
                d.triangle_count()
            );
        }
        for i in &s.ignored {
            println!("  ign {i}");
        }
        println!(
            "  cam {:?} {:?} {:?} {} {}",
            s.camera.eye, s.camera.target, s.camera.projection, s.camera.near, s.camera.far
        );
    }
}
