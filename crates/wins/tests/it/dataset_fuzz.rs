//! Fuzzing at the dataset level: a short simulated flight, damaged at random ([`mutate`]: IMU
//! rows, manifest values, log bytes, truth and barometer lines), run through the library's front
//! door (`wins::run_dataset`, what `wins run` calls). Every case must end without a panic in a
//! refusal that says why or in a run that accounts for every input ([`accounting`]).
//!
//! CI runs [`DEFAULT_CASES`] cases from a fixed seed; a longer campaign sets `WINS_FUZZ_CASES`:
//!
//! ```text
//! WINS_FUZZ_CASES=2000 cargo test --release -p wins --test it dataset_fuzz -- --nocapture
//! ```

pub mod accounting;
mod mutate;

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;
use std::sync::OnceLock;
use std::sync::atomic::{AtomicU64, Ordering};

use proptest::collection::vec;
use proptest::test_runner::TestRunner;
use wins::Config;
use wins::sim::{Scenario, simulate, write_dataset};

use self::accounting::check_outcome;
use self::mutate::{Mutation, mutation};
use super::pipeline_run::{TempDir, temp_dir};

/// Cases CI runs (each a whole run of an 8 s flight).
const DEFAULT_CASES: u32 = 24;

/// The base dataset: 8 s of the paper's circle started in the air (seed 1), written once per
/// test process (and, held by a static, left in the temporary folder).
fn base() -> &'static Path {
    static BASE: OnceLock<TempDir> = OnceLock::new();
    BASE.get_or_init(|| {
        let dir = temp_dir("fuzz-base");
        let mut s = Scenario::built_in("paper-circle").unwrap().airborne();
        s.seed = 1;
        s.duration_s = 8.0;
        let out = simulate(&s, &mut |_| {}).unwrap();
        write_dataset(&dir, &s, &out).unwrap();
        dir
    })
}

/// Copies the dataset folder `from` (one level of subfolders) to `to`.
fn copy_dataset(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_dataset(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), target).unwrap();
        }
    }
}

/// The text of a panic's payload.
fn panic_text(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| payload.downcast_ref::<&str>().map(|s| (*s).to_string()))
        .unwrap_or_else(|| "(no message)".into())
}

/// What a case ended in.
#[derive(Debug, PartialEq)]
enum Ending {
    /// A run whose counts add up.
    Run,
    /// A refusal with a reason.
    Refused,
}

/// Damages a copy of the base dataset with `mutations`, runs it and checks the outcome; the
/// folder is removed unless the case fails (its path is then in the message).
fn run_case(mutations: &[Mutation]) -> Result<Ending, String> {
    let dir = temp_dir("fuzz-case");
    copy_dataset(base(), &dir);
    for m in mutations {
        m.apply(&dir);
    }
    let outcome = catch_unwind(AssertUnwindSafe(|| {
        wins::run_dataset(&dir, &Config::default())
    }));
    let checked = match &outcome {
        Err(payload) => Err(format!("panicked: {}", panic_text(payload.as_ref()))),
        Ok(out) => check_outcome(&dir, out).map(|()| match out {
            Ok(_) => Ending::Run,
            Err(_) => Ending::Refused,
        }),
    };
    match checked {
        Ok(ending) => {
            let _ = std::fs::remove_dir_all(&dir);
            Ok(ending)
        }
        Err(why) => Err(format!("{mutations:?} ({}): {why}", dir.display())),
    }
}

/// `WINS_FUZZ_CASES`, or [`DEFAULT_CASES`].
fn cases() -> u32 {
    std::env::var("WINS_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(DEFAULT_CASES)
}

#[test]
fn damaged_datasets_are_refused_with_a_reason_or_fully_accounted() {
    let mut config = crate::proptest_config(cases());
    // Each case is a whole run: a failure shrinks within a bounded time.
    config.max_shrink_iters = 64;
    // The failing mutations are in the message (the runner has no source file to keep them by).
    config.failure_persistence = None;
    let mut runner = TestRunner::new(config);
    let (runs, refusals) = (AtomicU64::new(0), AtomicU64::new(0));
    let started = std::time::Instant::now();
    let result = runner.run(&vec(mutation(), 1..=3), |mutations| {
        match run_case(&mutations) {
            Ok(Ending::Run) => runs.fetch_add(1, Ordering::Relaxed),
            Ok(Ending::Refused) => refusals.fetch_add(1, Ordering::Relaxed),
            Err(why) => return Err(proptest::test_runner::TestCaseError::fail(why)),
        };
        Ok(())
    });
    println!(
        "dataset fuzz: {} cases, {} runs accounted, {} refusals with a reason, {:.1} s",
        cases(),
        runs.load(Ordering::Relaxed),
        refusals.load(Ordering::Relaxed),
        started.elapsed().as_secs_f64()
    );
    if let Err(e) = result {
        panic!("{e}");
    }
    // Both endings are reached: the damage is neither all harmless nor all fatal.
    assert!(runs.load(Ordering::Relaxed) > 0 && refusals.load(Ordering::Relaxed) > 0);
}

#[test]
fn the_undamaged_base_runs_and_a_miscounted_run_is_caught() {
    let out = wins::run_dataset(base(), &Config::default());
    check_outcome(base(), &out).unwrap();
    let run = out.unwrap();
    assert!(
        run.stats.fed() > 0 && run.inputs.imu.samples > 1000,
        "{:?}",
        run.stats
    );
    // The checker is not vacuous: each kind of miscount fails it.
    let spoilt: [fn(&mut wins::RunOutput); 5] = [
        |r| r.inputs.imu.not_finite += 1,
        |r| r.stats.per_ap[0].fed += 1,
        |r| r.stats.per_ap[0].log_skipped_bytes += 1,
        |r| r.inputs.aps[0].repeated += 1,
        |r| {
            r.packets.pop();
        },
    ];
    for (k, spoil) in spoilt.iter().enumerate() {
        let mut bad = run.clone();
        spoil(&mut bad);
        let checked = check_outcome(base(), &Ok(bad));
        assert!(checked.is_err(), "miscount {k} passed");
    }
}

#[test]
fn times_at_the_ends_of_the_clock_are_refused_or_accounted() {
    use self::mutate::At;
    // Found by this fuzzing: a first IMU row at i64::MIN ns overflowed the checks' sample
    // spacing (a panic with overflow checks, a wrong gap without). The others are the same
    // bound on the other files' times (`wins::time::MAX_ABS_NANOS`).
    let cases = [
        Mutation::ImuField {
            row: At::First,
            field: 0,
            value: "-9223372036854775808",
        },
        Mutation::ImuField {
            row: At::Last,
            field: 0,
            value: "9223372036854775807",
        },
        Mutation::ImuShift {
            from: At::Last,
            by_ns: 4_611_686_018_427_387_903,
        },
        Mutation::TruthField {
            line: At::Last,
            field: 0,
            value: "1e300",
        },
        Mutation::BaroField {
            line: At::First,
            field: 0,
            value: "-9223372036854775808",
        },
    ];
    for m in cases {
        run_case(std::slice::from_ref(&m)).unwrap();
    }
}
