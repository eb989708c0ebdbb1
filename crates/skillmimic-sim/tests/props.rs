//! Task props in the generated scene: they compile, add no degrees of freedom, and a scene
//! without props is the plain scene byte for byte.

use skillmimic_sim::Scene;
use skillmimic_sim::mjcf::{Prop, PropKind, SceneOptions, scene_xml};

#[test]
fn props_compile_add_no_dofs_and_leave_the_plain_scene_unchanged() {
    let plain = SceneOptions::default();
    let with = SceneOptions {
        props: vec![
            Prop {
                name: "target".into(),
                kind: PropKind::Marker { radius: 0.1 },
                pos: [2.0, -1.0, 0.1],
                rgba: [0.1, 0.8, 0.1, 0.6],
            },
            Prop {
                name: "crate".into(),
                kind: PropKind::Box { half: [0.3, 0.3, 0.25] },
                pos: [-2.0, 0.0, 0.25],
                rgba: [0.6, 0.4, 0.2, 1.0],
            },
        ],
        ..Default::default()
    };
    let (a, b) = (Scene::new(plain.clone()).unwrap(), Scene::new(with.clone()).unwrap());
    assert_eq!(a.sizes(), b.sizes(), "props are static world geoms");
    let xml = scene_xml(&with);
    assert!(
        xml.contains(
            "<geom name=\"target\" type=\"sphere\" size=\"0.1\" contype=\"0\" conaffinity=\"0\""
        ),
        "{xml}"
    );
    assert!(xml.contains("<geom name=\"crate\" type=\"box\" size=\"0.3 0.3 0.25\""));
    assert_eq!(scene_xml(&SceneOptions { props: Vec::new(), ..plain.clone() }), scene_xml(&plain));
    assert!(!scene_xml(&plain).contains("target"));
}
