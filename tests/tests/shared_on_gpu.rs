//! The shared crate's guarantee: every function the kernels use gives the same answer on the GPU
//! as on the CPU. The `difftest::difftest` kernel runs `gi_shared::difftest::evaluate` over a
//! buffer of inputs (random values and every extreme: zeros of both signs, denormals, huge and
//! tiny magnitudes, infinities, NaN); the CPU runs the same function on the same inputs.
//! Integer outputs must be bit-identical (cell indices snapped from floats may differ by one, and
//! only at a cell boundary); float outputs must be within the function's stated bound (NaN
//! matches NaN). A case may instead match the CPU's answer with denormals flushed to zero, which
//! Vulkan allows a GPU (NVIDIA's flush); on a GPU, a case whose CPU evaluation overflowed,
//! divided by zero or made a NaN, or whose inputs lie beyond 2^126, is left unchecked, since
//! Vulkan leaves that to the device. The
//! test prints, per function, the worst error seen and how many cases took either way out (on
//! lavapipe, none leaves unchecked).

use gi_host::vulkan::{Buffer, Context, Kernel, KernelModule};
use gi_shared::abi::WORKGROUP_SIZE;
use gi_shared::difftest::{
    DiffCase, DiffOutput, DiffPush, FUNCTIONS, FunctionInfo, OUTPUT_WORDS, SNAP_SOURCE_OFFSET,
    evaluate,
};
use gi_shared::random::Random;
use gi_tests::{computes_like_the_cpu, context, finish_without_validation_messages, variants};

/// Random cases per function, on top of the extremes.
const RANDOM_CASES: usize = 2048;

/// Floats every input word takes in turn, alone and combined.
const EXTREMES: [f32; 18] = [
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.5,
    1e-6,
    -1e-6,
    1e6,
    -1e6,
    1e-30,
    1e30,
    f32::MIN_POSITIVE,
    1e-40, // denormal
    f32::MAX,
    f32::MIN,
    f32::INFINITY,
    f32::NEG_INFINITY,
    f32::NAN,
];

fn cases() -> Vec<DiffCase> {
    let mut out = vec![];
    for (i, &a) in EXTREMES.iter().enumerate() {
        for (j, &b) in EXTREMES.iter().enumerate() {
            let c = EXTREMES[(i + j) % EXTREMES.len()];
            out.push(DiffCase {
                input: [a.to_bits(), b.to_bits(), c.to_bits(), (i * 31 + j) as u32],
            });
        }
    }
    let mut rng = Random::new(0x5eed, 1);
    for k in 0..RANDOM_CASES {
        let mut input = [0u32; 4];
        for w in &mut input {
            *w = match k % 4 {
                // Raw bits: every float class, every integer.
                0 => rng.next_u32(),
                // Unit range, where directions and colours live.
                1 => (rng.next_f32() * 2.0 - 1.0).to_bits(),
                // Log-uniform magnitudes from 1e-6 to 1e6, both signs.
                2 => {
                    let m = 10f32.powf(rng.next_f32() * 12.0 - 6.0);
                    (if rng.next_u32() & 1 == 0 { m } else { -m }).to_bits()
                }
                // Small integers (indices, counts, cell coordinates).
                _ => rng.next_u32() % 64,
            };
        }
        out.push(DiffCase { input });
    }
    out
}

fn ulp_distance(a: f32, b: f32) -> u32 {
    if a.is_nan() && b.is_nan() {
        return 0;
    }
    if a.is_nan() || b.is_nan() {
        return u32::MAX;
    }
    if a == b {
        return 0; // also +0 == -0
    }
    // Map the floats onto a line of integers where adjacent floats are adjacent.
    let key = |x: f32| {
        let bits = x.to_bits() as i64;
        if bits < 0x8000_0000 {
            bits
        } else {
            0x8000_0000 - bits
        }
    };
    (key(a) - key(b)).unsigned_abs().min(u64::from(u32::MAX)) as u32
}

gi_host::bindings! {
    /// The difftest kernel's set 0.
    struct Difftest<'a> {
        cases: &'a Buffer,
        out: &'a Buffer,
    }
}

fn run_on_gpu(ctx: &Context, cases: &[DiffCase]) -> Vec<Vec<DiffOutput>> {
    let module = KernelModule::new(ctx).unwrap();
    let kernel = Kernel::new::<Difftest>(
        ctx,
        &module,
        "difftest::difftest",
        std::mem::size_of::<DiffPush>() as u32,
    )
    .unwrap();
    drop(module);
    let input = Buffer::device_local(ctx, "difftest cases", cases, Default::default()).unwrap();
    let mut results = vec![];
    for function in 0..FUNCTIONS.len() as u32 {
        let output =
            Buffer::device_zeroed::<DiffOutput>(ctx, "difftest outputs", cases.len()).unwrap();
        let push = DiffPush {
            function,
            count: cases.len() as u32,
            _pad: [0; 2],
        };
        ctx.submit(|cmd| {
            kernel
                .dispatch(
                    ctx,
                    cmd,
                    &Difftest {
                        cases: &input,
                        out: &output,
                    },
                    bytemuck::bytes_of(&push),
                    [(cases.len() as u32).div_ceil(WORKGROUP_SIZE), 1, 1],
                )
                .unwrap();
            gi_host::vulkan::compute_barrier(ctx, cmd);
        })
        .unwrap();
        results.push(output.read_back::<DiffOutput>(ctx).unwrap());
        drop(output);
    }
    drop(input);
    drop(kernel);
    results
}

/// Whether `gpu` is within the tolerance of `cpu`, and by how much: the error divided by the
/// allowed error (at most 1 when it passes).
fn float_error(cpu: f32, gpu: f32, info: &FunctionInfo) -> f32 {
    if cpu.is_nan() && gpu.is_nan() || cpu == gpu {
        return 0.0;
    }
    let allowed = info.absolute + info.relative * cpu.abs();
    let err = (cpu - gpu).abs();
    if allowed == 0.0 || !err.is_finite() {
        return f32::INFINITY;
    }
    err / allowed
}

/// Whether a snapped integer may differ: the CPU's continuous coordinate lies within the
/// tolerance of a cell boundary, and the two cells are neighbours.
fn snap_ok(cpu: u32, gpu: u32, source: f32, info: &FunctionInfo) -> bool {
    let boundary = source.round();
    cpu.abs_diff(gpu) == 1
        && (source - boundary).abs() <= info.absolute + info.relative * source.abs()
}

/// How one case's GPU words compare with one CPU answer.
#[derive(Default)]
struct CaseCheck {
    worst_ulps: u32,
    worst_error: f32,
    int_mismatches: u32,
    snapped: u32,
    /// The first word outside its bound.
    bad_word: Option<usize>,
}

fn check_case(info: &FunctionInfo, want: &[u32], got: &[u32]) -> CaseCheck {
    let mut c = CaseCheck::default();
    for w in 0..OUTPUT_WORDS {
        let (cpu, gpu) = (want[w], got[w]);
        let ok = if info.float_outputs & (1 << w) != 0 {
            let (x, y) = (f32::from_bits(cpu), f32::from_bits(gpu));
            c.worst_ulps = c.worst_ulps.max(ulp_distance(x, y));
            let e = float_error(x, y, info);
            c.worst_error = c.worst_error.max(e);
            e <= 1.0
        } else if cpu == gpu {
            true
        } else if info.snapped_outputs & (1 << w) != 0
            && snap_ok(cpu, gpu, f32::from_bits(want[w + SNAP_SOURCE_OFFSET]), info)
        {
            c.snapped += 1;
            true
        } else {
            c.int_mismatches += 1;
            false
        };
        if !ok && c.bad_word.is_none() {
            c.bad_word = Some(w);
        }
    }
    c
}

/// MXCSR's mode bits that flush denormal inputs and results to zero (DAZ, FTZ).
const FLUSH_DENORMALS: u32 = (1 << 6) | (1 << 15);
/// MXCSR's sticky flags of an operation that made a NaN, divided by zero or overflowed.
const NON_FINITE_FLAGS: u32 = 0b1101;

/// `f(arg)` run with MXCSR's `mode` bits added (x86-64), and the exception flags it raised.
/// [`FLUSH_DENORMALS`] gives the answer of a GPU that flushes denormals, as Vulkan allows a
/// kernel that does not ask for `DenormPreserve` (NVIDIA's do; lavapipe keeps them). The
/// compiler assumes the default floating-point mode, so `f` and `arg` go through `black_box`:
/// it can neither inline `f` nor reuse a result computed outside. Elsewhere `f` runs as it is
/// and no flag is reported.
fn call_in_mode<A, R>(f: fn(A) -> R, arg: A, mode: u32) -> (R, u32) {
    let f = std::hint::black_box(f);
    let arg = std::hint::black_box(arg);
    #[cfg(target_arch = "x86_64")]
    {
        const FLAGS: u32 = 0b11_1111;
        let mut saved = 0u32;
        let mut after = 0u32;
        // SAFETY: reads and writes this thread's MXCSR only; it is restored below.
        unsafe {
            std::arch::asm!("stmxcsr [{}]", in(reg) &raw mut saved);
            let set = (saved | mode) & !FLAGS;
            std::arch::asm!("ldmxcsr [{}]", in(reg) &raw const set);
        }
        let r = std::hint::black_box(f(arg));
        // SAFETY: as above.
        unsafe {
            std::arch::asm!("stmxcsr [{}]", in(reg) &raw mut after);
            std::arch::asm!("ldmxcsr [{}]", in(reg) &raw const saved);
        }
        (r, after & FLAGS)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = mode;
        (f(arg), 0)
    }
}

/// Whether an input word, read as a float, is infinite, NaN or beyond 2^126 in magnitude, where
/// Vulkan's precision bounds end (a division's divisor, for one: NVIDIA's reciprocal of
/// `f32::MAX` is a denormal, flushed to 0).
fn beyond_precision_range(input: [u32; 4]) -> bool {
    input.iter().any(|&w| {
        let x = f32::from_bits(w);
        x.is_nan() || x.abs() > 2f32.powi(126)
    })
}

#[test]
fn flushing_denormals_changes_what_they_touch_only() {
    let product = |(a, b): (f32, f32)| a * b;
    assert_eq!(call_in_mode(product, (1e-40, 1.0), FLUSH_DENORMALS).0, 0.0);
    assert_eq!(
        call_in_mode(product, (1e-20, 1e-20), FLUSH_DENORMALS).0,
        0.0
    );
    assert_eq!(call_in_mode(product, (1.5, 1.0), FLUSH_DENORMALS).0, 1.5);
    assert_eq!(call_in_mode(product, (1e-40, 1.0), 0).0, 1e-40);
    let tiny = std::hint::black_box(1e-40f32);
    assert_eq!(
        tiny * std::hint::black_box(1.0),
        1e-40,
        "flushing leaked out"
    );
    // Overflow is reported, a finite product is not.
    assert_ne!(
        call_in_mode(product, (1e30, 1e30), 0).1 & NON_FINITE_FLAGS,
        0
    );
    assert_eq!(call_in_mode(product, (2.0, 3.0), 0).1 & NON_FINITE_FLAGS, 0);
}

#[test]
fn shared_functions_agree_between_cpu_and_gpu() {
    let cases = cases();
    for variant in variants() {
        let ctx = context(variant);
        // Vulkan leaves what happens through infinities and NaN to the device unless a kernel
        // asks for `SignedZeroInfNanPreserve`, and bounds precision only within 2^±126: only a
        // device computing like the CPU is held to the CPU's answer beyond.
        let strict = computes_like_the_cpu(&ctx);
        // A GPU may also fuse a product and a sum into one FMA (SPIR-V allows it without
        // `NoContraction`; NVIDIA's does): a few ulp more than the bounds, which are exact
        // arithmetic's (the Halton sequence's digit sum came out 1 ulp off on an H200).
        let contraction = if strict { 0.0 } else { 4.0 * f32::EPSILON };
        let gpu = run_on_gpu(&ctx, &cases);
        let mut failures = vec![];
        println!("{variant}: {} cases per function", cases.len());
        for (f, info) in FUNCTIONS.iter().enumerate() {
            let info = &FunctionInfo {
                relative: info.relative.max(contraction),
                ..*info
            };
            let (mut worst_ulps, mut worst_error, mut int_mismatches, mut snapped) =
                (0, 0f32, 0, 0);
            let (mut flushed, mut unchecked) = (0, 0);
            let mut first_failure = None;
            for (case, got) in cases.iter().zip(&gpu[f]) {
                let evaluate = |(f, input)| evaluate(f, input);
                let (want, flags) = call_in_mode(evaluate, (f as u32, case.input), 0);
                let mut check = check_case(info, &want, &got.words);
                if check.bad_word.is_some() {
                    // A GPU that flushes denormals matches the CPU flushing them.
                    let flushed_want =
                        call_in_mode(evaluate, (f as u32, case.input), FLUSH_DENORMALS).0;
                    let flushed_check = check_case(info, &flushed_want, &got.words);
                    if flushed_check.bad_word.is_none() {
                        check = flushed_check;
                        flushed += 1;
                    } else if !strict
                        && (flags & NON_FINITE_FLAGS != 0 || beyond_precision_range(case.input))
                    {
                        unchecked += 1;
                        continue;
                    }
                }
                worst_ulps = worst_ulps.max(check.worst_ulps);
                worst_error = worst_error.max(check.worst_error);
                int_mismatches += check.int_mismatches;
                snapped += check.snapped;
                if let (Some(w), None) = (check.bad_word, &first_failure) {
                    first_failure = Some(format!(
                        "{}: input {:08x?} word {w}: cpu {:08x} gpu {:08x}",
                        info.name, case.input, want[w], got.words[w]
                    ));
                }
            }
            println!(
                "  {:<28} worst {worst_ulps:>10} ulp = {worst_error:.3} of the bound, integer mismatches {int_mismatches}, snapped at cell boundaries {snapped}, cases matching the CPU with denormals flushed {flushed}, left to the device {unchecked}",
                info.name
            );
            failures.extend(first_failure);
        }
        finish_without_validation_messages(ctx);
        assert!(
            failures.is_empty(),
            "{variant}: CPU and GPU disagree:\n{}",
            failures.join("\n")
        );
    }
}

#[test]
fn ulp_distance_is_symmetric_and_counts_steps() {
    assert_eq!(ulp_distance(1.0, f32::from_bits(1.0f32.to_bits() + 3)), 3);
    assert_eq!(ulp_distance(0.0, -0.0), 0);
    assert_eq!(ulp_distance(f32::from_bits(1), -f32::from_bits(1)), 2);
    assert_eq!(ulp_distance(f32::NAN, f32::NAN), 0);
    assert_eq!(ulp_distance(f32::NAN, 1.0), u32::MAX);
    assert_eq!(ulp_distance(-1.0, -f32::from_bits(1.0f32.to_bits() + 1)), 1);
}
