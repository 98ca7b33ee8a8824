#[test]
fn counts() {
    use crate::world::{SceneKind, Trajectory};
    use faithd_core::camera::{CameraIntrinsics, Mounting};
    let cam = CameraIntrinsics::dvs240();
    let m = Mounting::forward();
    for kind in SceneKind::ALL {
        let scene = kind.build(1);
        let st = Trajectory::straight([-1.0, 0.1, -1.2], 0.0, 0.0, 2.0).state(0.05);
        let r = st.attitude.matrix();
        let w2c = m.body_to_camera * r.transpose();
        let view = scene.view(&st.position_m, &w2c, &cam);
        crate::world::scene::view::COUNTS.with(|c| *c.borrow_mut() = [0; 3]);
        let c2b = m.body_to_camera.transpose();
        for y in 0..180 { for x in 0..240 {
            let (xn, yn) = cam.normalise(x as f64, y as f64);
            let d = r * (c2b * nalgebra::Vector3::new(xn, yn, 1.0));
            view.shade(&d, x, y);
        }}
        let c = crate::world::scene::view::COUNTS.with(|c| *c.borrow());
        println!("{}: nodes {} per ray: rect checks {:.2} slab {:.2} solids {:.2}", kind.name(), scene_nodes(&scene), c[2] as f64 / 43200.0, c[0] as f64/43200.0, c[1] as f64/43200.0);
    }
}
fn scene_nodes(s: &crate::world::Scene) -> usize { s.solids.len() }
