//! The frame machinery on the GPU against the CPU, in both kernel variants with validation on:
//! device and workgroup atomics under contention, append lists with overflow, the multi-level
//! prefix scan, indirect dispatch from a counter, workgroup-memory reductions, and hash-cell
//! inserts under contention through the shared `insert_tile`; and the memory table's registry.

use gi_host::KernelVariant;
use gi_host::frame::{
    DispatchFromCounter, FiniteCheck, MemoryTable, Recorder, Scan, indirect_args, indirect_offset,
};
use gi_host::vulkan::{
    Bindings, Buffer, Context, Image, Kernel, KernelModule, MemoryLocation, compute_barrier,
};
use gi_shared::abi::WORKGROUP_SIZE;
use gi_shared::append_list::{append, clamped_count, overflow_count};
use gi_shared::atomics::AtomicWords;
use gi_shared::hash_cells::layout::HashGridParams;
use gi_shared::hash_cells::storage::slots_per_bucket;
use gi_shared::indirect::{DispatchIndirect, dispatch_for_count};
use gi_shared::light_grid::{LIGHT_GRID_BOUNDS_CLEAR, report_hit_bounds};
use gi_shared::machinery_tests::{
    AtomicsRecord, BOUNDS_COUNT_WORD, COUNTER_INVOCATIONS, COUNTER_ITEMS, FOUND, FULL, INSERTED,
    MachineryPush, WORD_CAS, WORD_MAX, WORD_MIN, WORD_STORE, WORD_SUM, WORD_SWAP, WORD_TICKET,
    WorkgroupRecord, appended_items, contention_descriptor, contention_value, item_value,
};
use gi_shared::random::Random;
use gi_shared::scan::exclusive_scan;
use gi_tests::{context, finish_without_validation_messages, variants};
use std::collections::{BTreeMap, BTreeSet};

/// A kernel of `module` with set 0 bound as `B` and push constants of `P`.
fn kernel<B: Bindings, P>(ctx: &Context, module: &KernelModule, entry: &str) -> Kernel {
    Kernel::new::<B>(ctx, module, entry, std::mem::size_of::<P>() as u32)
        .unwrap_or_else(|e| panic!("{entry}: {e}"))
}

gi_host::bindings! {
    /// `atomics_contention`'s set 0 (`kernels::machinery_tests::atomics_contention`).
    struct AtomicsContention<'a> {
        words: &'a Buffer,
        records: &'a Buffer,
        groups: &'a Buffer,
    }
}

gi_host::bindings! {
    /// `append_items`'s set 0 (`kernels::machinery_tests::append_items`).
    struct AppendItems<'a> {
        counters: &'a Buffer,
        list: &'a Buffer,
    }
}

gi_host::bindings! {
    /// `touch_items`'s set 0 (`kernels::machinery_tests::touch_items`).
    struct TouchItems<'a> {
        counters: &'a Buffer,
        list: &'a Buffer,
        touched: &'a Buffer,
    }
}

gi_host::bindings! {
    /// `point_bounds`'s set 0 (`kernels::machinery_tests::point_bounds`).
    struct PointBounds<'a> {
        points: &'a Buffer,
        bounds: &'a Buffer,
    }
}

gi_host::bindings! {
    /// `insert_keys`'s set 0 (`kernels::machinery_tests::insert_keys`).
    struct InsertKeys<'a> {
        params: &'a Buffer,
        keys: &'a Buffer,
        outcomes: &'a Buffer,
    }
}

fn groups(invocations: u32) -> [u32; 3] {
    [invocations.div_ceil(WORKGROUP_SIZE).max(1), 1, 1]
}

/// Runs `check` on a fresh context of each variant, then fails on any validation message.
fn each_variant(mut check: impl FnMut(&Context, &KernelModule, KernelVariant)) {
    for variant in variants() {
        let ctx = context(variant);
        let module = KernelModule::new(&ctx).unwrap();
        check(&ctx, &module, variant);
        drop(module);
        finish_without_validation_messages(ctx);
    }
}

#[test]
fn device_and_workgroup_atomics_agree_with_the_cpu_under_contention() {
    // A partial last workgroup: its idle invocations must not count.
    let n = 37 * WORKGROUP_SIZE + 5;
    let seed = 11;
    each_variant(|ctx, module, variant| {
        let k = kernel::<AtomicsContention, MachineryPush>(
            ctx,
            module,
            "machinery_tests::atomics_contention",
        );
        let mut initial = vec![0u32; WORD_STORE + n as usize];
        initial[WORD_MIN] = u32::MAX;
        let words =
            Buffer::device_local(ctx, "atomic words", &initial, Default::default()).unwrap();
        let records = Buffer::device_zeroed::<AtomicsRecord>(ctx, "records", n as usize).unwrap();
        let group_count = n.div_ceil(WORKGROUP_SIZE) as usize;
        let workgroups =
            Buffer::device_zeroed::<WorkgroupRecord>(ctx, "workgroup records", group_count)
                .unwrap();
        let push = MachineryPush {
            count: n,
            seed,
            ..Default::default()
        };
        ctx.submit(|cmd| {
            k.dispatch(
                ctx,
                cmd,
                &AtomicsContention {
                    words: &words,
                    records: &records,
                    groups: &workgroups,
                },
                bytemuck::bytes_of(&push),
                groups(n),
            )
            .unwrap();
            compute_barrier(ctx, cmd);
        })
        .unwrap();
        let got = words.read_back::<u32>(ctx).unwrap();
        let recs = records.read_back::<AtomicsRecord>(ctx).unwrap();
        let wgs = workgroups.read_back::<WorkgroupRecord>(ctx).unwrap();
        for b in [words, records, workgroups] {
            drop(b);
        }
        drop(k);

        // The CPU runs the same operations one invocation after another.
        let mut cpu = initial.clone();
        let mut cpu_tickets = vec![];
        for i in 0..n {
            let w: &mut [u32] = &mut cpu;
            let v = contention_value(i, seed);
            w.fetch_add(WORD_SUM, i + 1);
            w.fetch_min(WORD_MIN, v);
            w.fetch_max(WORD_MAX, v);
            w.compare_exchange(WORD_CAS, 0, i + 1);
            AtomicWords::swap(w, WORD_SWAP, i + 1);
            cpu_tickets.push(w.fetch_add(WORD_TICKET, 1));
            w.store(WORD_STORE + i as usize, v);
        }
        // Order-independent words are bit-identical.
        for word in [WORD_SUM, WORD_MIN, WORD_MAX, WORD_TICKET] {
            assert_eq!(got[word], cpu[word], "{variant}: word {word}");
        }
        assert_eq!(
            got[WORD_STORE..],
            cpu[WORD_STORE..],
            "{variant}: stored words"
        );
        // Order-dependent ones: exactly one compare-exchange won, and every other saw the winner.
        let winners: Vec<u32> = (0..n).filter(|&i| recs[i as usize].cas_old == 0).collect();
        assert_eq!(
            winners.len(),
            1,
            "{variant}: compare-exchange winners {winners:?}"
        );
        assert_eq!(got[WORD_CAS], winners[0] + 1, "{variant}");
        assert!(
            recs.iter()
                .all(|r| r.cas_old == 0 || r.cas_old == winners[0] + 1),
            "{variant}: a compare-exchange saw a value nobody stored"
        );
        // Swaps form one chain: the old values and the final one are 0 ..= n, each once.
        let mut chain: Vec<u32> = recs.iter().map(|r| r.swap_old).collect();
        chain.push(got[WORD_SWAP]);
        chain.sort_unstable();
        assert!(
            chain.iter().copied().eq(0..=n),
            "{variant}: swap chain broken"
        );
        // Tickets are distinct: 0 .. n.
        let mut tickets: Vec<u32> = recs.iter().map(|r| r.ticket).collect();
        tickets.sort_unstable();
        assert_eq!(tickets, cpu_tickets, "{variant}: tickets");
        for (i, r) in recs.iter().enumerate() {
            assert_eq!(
                r.loaded,
                contention_value(i as u32, seed),
                "{variant}: load {i}"
            );
        }
        // Workgroup memory: per workgroup, count, minimum, maximum and distinct tickets.
        for (g, wg) in wgs.iter().enumerate() {
            let members: Vec<u32> =
                (g as u32 * WORKGROUP_SIZE..n.min((g as u32 + 1) * WORKGROUP_SIZE)).collect();
            let values = members.iter().map(|&i| contention_value(i, seed));
            let want = WorkgroupRecord {
                count: members.len() as u32,
                min: values.clone().min().unwrap(),
                max: values.max().unwrap(),
                _pad: 0,
            };
            assert_eq!(*wg, want, "{variant}: workgroup {g}");
            let mut t: Vec<u32> = members
                .iter()
                .map(|&i| recs[i as usize].workgroup_ticket)
                .collect();
            t.sort_unstable();
            assert!(
                t.iter().copied().eq(0..members.len() as u32),
                "{variant}: workgroup {g}"
            );
        }
    });
}

/// The values and attempt count the CPU's append list ends with for `n` invocations.
fn cpu_append(n: u32, seed: u32, capacity: u32) -> (Vec<u32>, u32) {
    let mut counter = [0u32];
    let mut list = vec![0u32; capacity as usize];
    for i in 0..n {
        for k in 0..appended_items(i, seed) {
            if let Some(slot) = append(&mut counter[..], 0, capacity) {
                list[slot as usize] = item_value(i, k);
            }
        }
    }
    (list, counter[0])
}

/// Appends on the GPU: the counter, then the list.
fn gpu_append(
    ctx: &Context,
    module: &KernelModule,
    n: u32,
    seed: u32,
    capacity: u32,
) -> (Vec<u32>, Vec<u32>) {
    let k = kernel::<AppendItems, MachineryPush>(ctx, module, "machinery_tests::append_items");
    let counters = Buffer::device_zeroed::<u32>(ctx, "counters", 2).unwrap();
    let list = Buffer::device_zeroed::<u32>(ctx, "list", capacity.max(1) as usize).unwrap();
    let push = MachineryPush {
        count: n,
        seed,
        capacity,
        _pad: 0,
    };
    ctx.submit(|cmd| {
        k.dispatch(
            ctx,
            cmd,
            &AppendItems {
                counters: &counters,
                list: &list,
            },
            bytemuck::bytes_of(&push),
            groups(n),
        )
        .unwrap();
        compute_barrier(ctx, cmd);
    })
    .unwrap();
    let out = (
        counters.read_back::<u32>(ctx).unwrap(),
        list.read_back::<u32>(ctx).unwrap(),
    );
    drop(counters);
    drop(list);
    drop(k);
    out
}

#[test]
fn append_lists_hold_every_value_once_and_report_overflow() {
    let (n, seed) = (50 * WORKGROUP_SIZE + 17, 3);
    let (all, attempts) = cpu_append(n, seed, u32::MAX >> 8);
    let expected: BTreeSet<u32> = all[..attempts as usize].iter().copied().collect();
    assert_eq!(expected.len(), attempts as usize, "item values are unique");
    each_variant(|ctx, module, variant| {
        // Room for everything: the list is the CPU's, in some order.
        let (counters, list) = gpu_append(ctx, module, n, seed, attempts + 10);
        assert_eq!(counters[COUNTER_ITEMS], attempts, "{variant}");
        let got: BTreeSet<u32> = list[..attempts as usize].iter().copied().collect();
        assert_eq!(
            got.len(),
            attempts as usize,
            "{variant}: a value appears twice"
        );
        assert_eq!(got, expected, "{variant}");
        assert!(
            list[attempts as usize..].iter().all(|&v| v == 0),
            "{variant}"
        );
        // Too small: the counter still counts every attempt, the list is full of distinct values.
        let capacity = attempts / 3;
        let (counters, list) = gpu_append(ctx, module, n, seed, capacity);
        let (_, cpu_attempts) = cpu_append(n, seed, capacity);
        assert_eq!(counters[COUNTER_ITEMS], cpu_attempts, "{variant}");
        assert_eq!(
            overflow_count(counters[COUNTER_ITEMS], capacity),
            attempts - capacity
        );
        let got: BTreeSet<u32> = list.iter().copied().collect();
        assert_eq!(
            got.len(),
            capacity as usize,
            "{variant}: a value appears twice"
        );
        assert!(
            got.is_subset(&expected),
            "{variant}: a value nobody appended"
        );
    });
}

#[test]
fn indirect_dispatch_processes_exactly_the_appended_items() {
    let seed = 5;
    // (invocations, capacity): some items, none at all, and more than fit.
    let cases = [
        (20 * WORKGROUP_SIZE + 3, 1 << 16),
        (0, 64),
        (30 * WORKGROUP_SIZE, 1000),
    ];
    each_variant(|ctx, module, variant| {
        let append_k =
            kernel::<AppendItems, MachineryPush>(ctx, module, "machinery_tests::append_items");
        let touch =
            kernel::<TouchItems, MachineryPush>(ctx, module, "machinery_tests::touch_items");
        let from_counter = DispatchFromCounter::new(ctx, module).unwrap();
        for (n, capacity) in cases {
            let (_, attempts) = cpu_append(n, seed, capacity);
            let counters = Buffer::device_zeroed::<u32>(ctx, "counters", 2).unwrap();
            let list = Buffer::device_zeroed::<u32>(ctx, "list", capacity as usize).unwrap();
            let touched =
                Buffer::device_zeroed::<u32>(ctx, "touched", (4 * n).max(1) as usize).unwrap();
            // Two argument slots: the second one is used, to exercise the offset.
            let args = indirect_args(ctx, "touch arguments", 2).unwrap();
            let push = MachineryPush {
                count: n,
                seed,
                capacity,
                _pad: 0,
            };
            // One submission: the host never learns the count.
            // The recorder places every barrier: after the append, after the arguments (an
            // indirect read), and for the host's reads.
            ctx.submit(|cmd| {
                let mut rec = Recorder::new(ctx, cmd, None);
                let appended = AppendItems {
                    counters: &counters,
                    list: &list,
                };
                let push = bytemuck::bytes_of(&push);
                rec.dispatch(&append_k, &appended, push, groups(n)).unwrap();
                let count = COUNTER_ITEMS as u32;
                from_counter
                    .record(&mut rec, &counters, count, capacity, &args, 1)
                    .unwrap();
                let touching = TouchItems {
                    counters: &counters,
                    list: &list,
                    touched: &touched,
                };
                rec.dispatch_indirect(&touch, &touching, push, &args, indirect_offset(1))
                    .unwrap();
                rec.finish();
            })
            .unwrap();
            let c = counters.read_back::<u32>(ctx).unwrap();
            let l = list.read_back::<u32>(ctx).unwrap();
            let t = touched.read_back::<u32>(ctx).unwrap();
            let a = args.read_back::<DispatchIndirect>(ctx).unwrap();
            for b in [counters, list, touched, args] {
                drop(b);
            }
            let max_groups = ctx.capabilities().max_workgroup_count[0];
            let want = dispatch_for_count(attempts, capacity, max_groups);
            let case = format!("{variant}, {n} invocations, capacity {capacity}");
            assert_eq!(c[COUNTER_ITEMS], attempts, "{case}");
            assert_eq!(a[1], want, "{case}");
            assert_eq!(c[COUNTER_INVOCATIONS], want.x * WORKGROUP_SIZE, "{case}");
            let kept = clamped_count(attempts, capacity) as usize;
            let items: BTreeSet<u32> = l[..kept].iter().copied().collect();
            assert_eq!(items.len(), kept, "{case}");
            for (v, &times) in t.iter().enumerate() {
                let want = u32::from(items.contains(&(v as u32)));
                assert_eq!(times, want, "{case}: item {v} touched {times} times");
            }
        }
        drop(append_k);
        drop(touch);
        drop(from_counter);
    });
}

#[test]
fn the_gpu_scan_equals_the_cpu_exactly() {
    let sizes = [0u32, 1, 63, 64, 65, 4096, 4097, 1_000_000];
    let mut rng = Random::new(0x5ca9, 7);
    let inputs: Vec<Vec<u32>> = sizes
        .iter()
        .map(|&n| {
            (0..n)
                .map(|i| match i % 3 {
                    // Large values: the sums wrap, on both sides alike.
                    0 => rng.next_u32(),
                    1 => rng.next_u32() % 4,
                    _ => 0,
                })
                .collect()
        })
        .collect();
    each_variant(|ctx, module, variant| {
        let scan = Scan::new(ctx, module, 1_000_000).unwrap();
        for (n, input) in sizes.iter().zip(&inputs) {
            let mut want = input.clone();
            let total = exclusive_scan(&mut want);
            // A padded buffer: words past `n` stay as they were.
            let mut padded = input.clone();
            padded.extend([0xdead_beef, 7]);
            let data = Buffer::device_local(ctx, "scan data", &padded, Default::default()).unwrap();
            let sentinel = [1u32, 2, 3, 4];
            let counters =
                Buffer::device_local(ctx, "scan total", &sentinel, Default::default()).unwrap();
            ctx.submit(|cmd| {
                let mut rec = Recorder::new(ctx, cmd, None);
                scan.record(&mut rec, &data, *n, Some((&counters, 2)))
                    .unwrap();
                rec.finish();
            })
            .unwrap();
            let got = data.read_back::<u32>(ctx).unwrap();
            let got_total = counters.read_back::<u32>(ctx).unwrap();
            drop(data);
            drop(counters);
            let first_wrong = got.iter().zip(&want).position(|(g, w)| g != w);
            assert_eq!(first_wrong, None, "{variant}: scan of {n} words");
            assert_eq!(got[*n as usize..], [0xdead_beef, 7], "{variant}: {n} words");
            assert_eq!(got_total, [1, 2, total, 4], "{variant}: total of {n} words");
        }
        // Without a total, and a size the scan was not made for.
        let data =
            Buffer::device_local(ctx, "scan data", &[5u32, 6, 7], Default::default()).unwrap();
        ctx.submit(|cmd| {
            let mut rec = Recorder::new(ctx, cmd, None);
            scan.record(&mut rec, &data, 3, None).unwrap();
            rec.finish();
        })
        .unwrap();
        assert_eq!(data.read_back::<u32>(ctx).unwrap(), [0, 5, 11]);
        let too_many =
            ctx.submit(|cmd| scan.record(&mut Recorder::new(ctx, cmd, None), &data, 4, None));
        assert!(
            too_many.unwrap().is_err(),
            "{variant}: 4 words in a buffer of 3"
        );
        drop(data);
        drop(scan);
    });
}

#[test]
fn workgroup_bounds_reduction_equals_the_cpu() {
    let mut rng = Random::new(0xb0b, 3);
    let n = 5000u32;
    let points: Vec<[f32; 4]> = (0..n)
        .map(|i| match i % 97 {
            // Non-finite points are skipped on both sides.
            0 => [f32::NAN, 0.0, 0.0, 0.0],
            1 => [0.0, f32::INFINITY, 0.0, 0.0],
            _ => {
                let mut c = || (rng.next_f32() - 0.5) * 200.0;
                [c(), c(), c(), 0.0]
            }
        })
        .collect();
    let mut want = LIGHT_GRID_BOUNDS_CLEAR.to_vec();
    want.push(0);
    for p in &points {
        let v = glam::Vec3::new(p[0], p[1], p[2]);
        if v.is_finite() {
            report_hit_bounds(&mut want[..], 0, v);
            want[BOUNDS_COUNT_WORD] += 1;
        }
    }
    each_variant(|ctx, module, variant| {
        let k = kernel::<PointBounds, MachineryPush>(ctx, module, "machinery_tests::point_bounds");
        let input = Buffer::device_local(ctx, "points", &points, Default::default()).unwrap();
        let mut clear = LIGHT_GRID_BOUNDS_CLEAR.to_vec();
        clear.push(0);
        let bounds = Buffer::device_local(ctx, "bounds", &clear, Default::default()).unwrap();
        let push = MachineryPush {
            count: n,
            ..Default::default()
        };
        ctx.submit(|cmd| {
            k.dispatch(
                ctx,
                cmd,
                &PointBounds {
                    points: &input,
                    bounds: &bounds,
                },
                bytemuck::bytes_of(&push),
                groups(n),
            )
            .unwrap();
            compute_barrier(ctx, cmd);
        })
        .unwrap();
        assert_eq!(bounds.read_back::<u32>(ctx).unwrap(), want, "{variant}");
        drop(input);
        drop(bounds);
        drop(k);
    });
}

#[test]
fn hash_cell_inserts_under_contention_are_exact() {
    let seed = 9;
    let invocations = 64 * WORKGROUP_SIZE;
    let mut params = HashGridParams::new(glam::Vec3::ZERO, 0.01, 0);
    params.num_buckets_log2 = 2;
    let slots = slots_per_bucket(&params);
    // About 10 keys per bucket (some buckets fill, some not), then far more than fit.
    for keys in [40u32, 100] {
        // The CPU's keys per bucket.
        let mut per_bucket: BTreeMap<u32, u32> = BTreeMap::new();
        for key in 0..keys {
            *per_bucket
                .entry(contention_descriptor(key, keys, seed, params.num_buckets_log2).bucket)
                .or_default() += 1;
        }
        each_variant(|ctx, module, variant| {
            let k =
                kernel::<InsertKeys, MachineryPush>(ctx, module, "machinery_tests::insert_keys");
            let p = Buffer::device_local(ctx, "params", &[params], Default::default()).unwrap();
            let table =
                Buffer::device_zeroed::<u32>(ctx, "keys", params.tile_count() as usize).unwrap();
            let outcomes =
                Buffer::device_zeroed::<u32>(ctx, "outcomes", invocations as usize).unwrap();
            let push = MachineryPush {
                count: invocations,
                seed,
                capacity: keys,
                _pad: 0,
            };
            ctx.submit(|cmd| {
                k.dispatch(
                    ctx,
                    cmd,
                    &InsertKeys {
                        params: &p,
                        keys: &table,
                        outcomes: &outcomes,
                    },
                    bytemuck::bytes_of(&push),
                    groups(invocations),
                )
                .unwrap();
                compute_barrier(ctx, cmd);
            })
            .unwrap();
            let table_words = table.read_back::<u32>(ctx).unwrap();
            let outcome = outcomes.read_back::<u32>(ctx).unwrap();
            for b in [p, table, outcomes] {
                drop(b);
            }
            drop(k);
            let case = format!("{variant}, {keys} keys");
            // Where each key landed: at most once, in its own bucket.
            let mut slot_of: BTreeMap<u32, u32> = BTreeMap::new();
            for (tile, &checksum) in table_words.iter().enumerate() {
                if checksum != 0 {
                    let key = checksum - 1;
                    let bucket = contention_descriptor(key, keys, seed, 2).bucket;
                    assert_eq!(
                        tile as u32 / slots,
                        bucket,
                        "{case}: key {key} in the wrong bucket"
                    );
                    assert!(
                        slot_of.insert(key, tile as u32).is_none(),
                        "{case}: key {key} twice"
                    );
                }
            }
            for (&bucket, &count) in &per_bucket {
                let stored = slot_of
                    .keys()
                    .filter(|&&key| contention_descriptor(key, keys, seed, 2).bucket == bucket);
                assert_eq!(
                    stored.count() as u32,
                    count.min(slots),
                    "{case}: bucket {bucket}"
                );
            }
            // Every invocation's outcome agrees with the table: one Inserted per stored key,
            // Found for the rest, Full only for keys left out of a bucket holding 16 others.
            let mut inserted: BTreeMap<u32, u32> = BTreeMap::new();
            for (i, &o) in outcome.iter().enumerate() {
                let key = i as u32 % keys;
                match slot_of.get(&key) {
                    Some(&tile) if o == INSERTED | tile => *inserted.entry(key).or_default() += 1,
                    Some(&tile) => assert_eq!(o, FOUND | tile, "{case}: invocation {i}"),
                    None => {
                        assert_eq!(o, FULL, "{case}: invocation {i} lost key {key}");
                        let bucket = contention_descriptor(key, keys, seed, 2).bucket;
                        assert!(per_bucket[&bucket] > slots, "{case}: Full with room left");
                    }
                }
            }
            assert!(
                inserted.values().all(|&c| c == 1),
                "{case}: a key inserted twice"
            );
            assert_eq!(
                inserted.len(),
                slot_of.len(),
                "{case}: a stored key nobody inserted"
            );
        });
    }
}

#[test]
fn the_memory_table_lists_live_buffers_and_images_by_name() {
    each_variant(|ctx, _, variant| {
        let before = MemoryTable::of(ctx).total_bytes();
        let buffer = Buffer::device_zeroed::<u32>(ctx, "table test buffer", 1 << 18).unwrap();
        // The G-buffer's depth format: 4 bytes per texel.
        let depth = gi_host::gbuffer::FORMATS[0];
        let image = Image::new(ctx, "table test image", 64, 32, depth).unwrap();
        let table = MemoryTable::of(ctx);
        let row = |name: &str| table.rows.iter().find(|r| r.name == name).cloned();
        let b = row("table test buffer").expect("the buffer is listed");
        assert_eq!((b.kind, b.bytes), ("buffer", 1 << 20), "{variant}");
        assert_eq!(b.location, MemoryLocation::GpuOnly, "{variant}");
        let i = row("table test image").expect("the image is listed");
        assert_eq!(i.kind, "image", "{variant}");
        assert!(
            i.bytes >= 64 * 32 * 4,
            "{variant}: image of {} bytes",
            i.bytes
        );
        assert_eq!(table.total_bytes(), before + b.bytes + i.bytes, "{variant}");
        assert!(table.to_string().contains("table test image"), "{variant}");
        drop(buffer);
        drop(image);
        assert_eq!(
            MemoryTable::of(ctx).total_bytes(),
            before,
            "{variant}: freed"
        );
    });
}

gi_host::bindings! {
    /// The smoke kernel's set 0: it writes `out`.
    struct Smoke<'a> {
        out: &'a Buffer,
    }
}

gi_host::bindings! {
    /// The finite check's set 0: it reads `words` and writes `counts`.
    struct CountNonFinite<'a> {
        words: &'a Buffer,
        counts: &'a Buffer,
    }
}

/// The recorder places a barrier exactly where a command depends on an earlier one: none between
/// independent dispatches, one buffer barrier for a read after a write, and one (with the memory
/// barrier of the write before) for a write after that read; the validation layer's
/// synchronization checks agree.
#[test]
fn the_recorder_places_barriers_only_where_a_dependency_needs_one() {
    let ctx = context(KernelVariant::Software);
    let module = KernelModule::new(&ctx).unwrap();
    let smoke = Kernel::new::<Smoke>(&ctx, &module, "smoke::smoke", 0).unwrap();
    let push = std::mem::size_of::<gi_shared::finite_check::FiniteCheckPush>() as u32;
    let check = Kernel::new::<CountNonFinite>(&ctx, &module, FiniteCheck::ENTRY, push).unwrap();
    drop(module);
    let [a, b] = ["a", "b"].map(|n| Buffer::device_zeroed::<u32>(&ctx, n, 64).unwrap());
    let counts = Buffer::device_zeroed::<u32>(&ctx, "counts", 8).unwrap();
    let push = gi_shared::finite_check::FiniteCheckPush {
        word_count: 64,
        record_words: 1,
        float_mask: 1,
        slot: 0,
    };
    let seen = ctx
        .submit(|cmd| -> gi_host::Result<Vec<(u32, u32)>> {
            let mut rec = Recorder::new(&ctx, cmd, None);
            let mut seen = vec![];
            let mut step = |rec: &Recorder<'_>| {
                let c = rec.counts();
                seen.push((c.barriers, c.buffer_barriers));
            };
            rec.dispatch(&smoke, &Smoke { out: &a }, &[], [1, 1, 1])?;
            rec.dispatch(&smoke, &Smoke { out: &b }, &[], [1, 1, 1])?;
            step(&rec);
            let reading = CountNonFinite {
                words: &a,
                counts: &counts,
            };
            rec.dispatch(&check, &reading, bytemuck::bytes_of(&push), [1, 1, 1])?;
            step(&rec);
            rec.dispatch(&smoke, &Smoke { out: &a }, &[], [1, 1, 1])?;
            step(&rec);
            rec.finish();
            Ok(seen)
        })
        .unwrap()
        .unwrap();
    // Independent: nothing. Read after write: one barrier on `a`. Write after that read and
    // the first write: one more barrier on `a`.
    assert_eq!(seen, [(0, 0), (1, 1), (2, 2)]);
    drop((smoke, check, a, b, counts));
    finish_without_validation_messages(ctx);
}
