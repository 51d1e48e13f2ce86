//! Fuzzing the controller-file parser (`hevo eval`, `hevo replay`, fixed children of an
//! experiment and every batch a worker receives read it): the shipped controllers with bytes
//! changed, cut and spliced. Reading, validating and building a runnable controller must
//! never panic; a file that is accepted must also run. The case count bounds the time.

use hevo_sim_core::SensorFrame;
use hevo_sim_core::{Controller, ControllerFile};
use proptest::prelude::*;

const SHIPPED: [&str; 3] = [
    include_str!("../../../controllers/follow_wall.json"),
    include_str!("../../../controllers/solve_maze.json"),
    include_str!("../../../controllers/rescue.json"),
];

fn mutated() -> impl Strategy<Value = String> {
    (
        0..SHIPPED.len(),
        prop::collection::vec((any::<u32>(), any::<u8>(), 0..3u8), 1..8),
    )
        .prop_map(|(file, edits)| {
            let mut bytes = SHIPPED[file].as_bytes().to_vec();
            for (at, byte, kind) in edits {
                if bytes.is_empty() {
                    break;
                }
                let at = at as usize % bytes.len();
                match kind {
                    0 => bytes[at] = byte,
                    1 => bytes.truncate(at),
                    _ => {
                        let end = (at + 40).min(bytes.len());
                        let copy = bytes[at..end].to_vec();
                        bytes.splice(at..at, copy);
                    }
                }
            }
            String::from_utf8_lossy(&bytes).into_owned()
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn edited_controller_files_never_panic(text in mutated()) {
        if let Ok(file) = ControllerFile::from_json_str(&text)
            && file.free_node_topology().is_none()
            && let Ok(mut controller) = Controller::new(&file, None)
        {
            for _ in 0..5 {
                controller.step(&SensorFrame::default(), 0.1);
            }
        }
    }

    #[test]
    fn random_text_never_panics(text in "\\PC{0,300}") {
        let _ = ControllerFile::from_json_str(&text);
    }
}
