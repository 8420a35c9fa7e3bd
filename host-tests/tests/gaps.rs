//! Issue 6 §3: flights with one hidden effect; the model-gap analysis must name it.

use aerosid_host::gaps::hidden::{flight, HiddenKind};
use aerosid_host::gaps::{report, run_gaps, GapSettings};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

#[test]
#[ignore = "exploration"]
fn explore() {
    let kinds: Vec<Option<HiddenKind>> = std::iter::once(None).chain(HiddenKind::ALL.into_iter().map(Some)).collect();
    for (i, k) in kinds.iter().enumerate() {
        let mut rng = ChaCha8Rng::seed_from_u64(100 + i as u64);
        let e = k.map(|k| k.draw(&mut rng));
        let t0 = std::time::Instant::now();
        let f = flight(e.as_ref(), 90.0, 7 + i as u64).unwrap();
        let t1 = t0.elapsed();
        let r = run_gaps(&f, &GapSettings::default()).unwrap();
        println!("sim {:?} analysis {:?}", t1, t0.elapsed() - t1);
        println!("{}", report::table(&r));
        if let Some(e) = e {
            println!("EXPECTED {:?}", e.expected());
        }
    }
}
