//! Fuzzing what a master and a worker decode from each other: random bytes as every message
//! type, and the conversions from decoded messages to sim-core's values (results, samples,
//! controller templates, task configurations). None may panic; malformed input is an error.
//! The case count bounds the time (`PROPTEST_CASES` raises it).

use hevo_proto::convert;
use hevo_proto::v1;
use proptest::prelude::*;
use prost::Message;

fn decode_all(bytes: &[u8]) {
    let _ = v1::SubmitJobRequest::decode(bytes);
    let _ = v1::LeaseBatchRequest::decode(bytes);
    let _ = v1::ExtendLeaseRequest::decode(bytes);
    let _ = v1::ReleaseBatchRequest::decode(bytes);
    let _ = v1::FailBatchRequest::decode(bytes);
    let _ = v1::GetJobRequest::decode(bytes);
    if let Ok(batch) = v1::Batch::decode(bytes) {
        let _ = convert::template_from_json(&batch.template_json, &batch.template_hash);
        let _ = convert::task_from_json(&batch.task_json, &batch.task_hash);
        for sample in &batch.samples {
            let _ = convert::sample_from_proto(sample);
        }
    }
    if let Ok(request) = v1::CompleteBatchRequest::decode(bytes) {
        let _ = convert::results_from_proto(&request.genomes);
    }
}

fn sample_result() -> impl Strategy<Value = v1::SampleResult> {
    (
        any::<f32>(),
        any::<bool>(),
        any::<u32>(),
        any::<u32>(),
        any::<u32>(),
        prop::collection::vec(any::<u32>(), 0..5),
        prop::collection::vec(any::<u32>(), 0..5),
        prop::collection::vec(any::<u32>(), 0..5),
        prop::collection::vec(any::<u32>(), 0..5),
        prop::collection::vec(any::<f32>(), 0..20),
        // The endings, unset and values no hevo sends.
        -1i32..6,
    )
        .prop_map(
            |(
                fitness,
                solved,
                stage,
                variant,
                cycles,
                sub_cycles,
                sub_correct,
                active,
                activations,
                descriptor,
                ending,
            )| {
                v1::SampleResult {
                    fitness,
                    solved,
                    collided: !solved,
                    stage,
                    variant,
                    cycles,
                    sub_task_cycles: sub_cycles,
                    sub_task_correct: sub_correct,
                    node_active_cycles: active,
                    node_activations: activations,
                    descriptor,
                    ending,
                }
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..512)) {
        decode_all(&bytes);
    }

    #[test]
    fn any_results_convert_or_are_refused(
        genomes in prop::collection::vec(prop::collection::vec(sample_result(), 0..4), 0..4)
    ) {
        let genomes: Vec<v1::GenomeResult> =
            genomes.into_iter().map(|samples| v1::GenomeResult { samples }).collect();
        let _ = convert::results_from_proto(&genomes);
        let bytes = v1::CompleteBatchRequest { genomes, ..Default::default() }.encode_to_vec();
        decode_all(&bytes);
    }

    #[test]
    fn any_json_text_is_no_template_or_task_unless_it_is_one(text in "\\PC{0,300}", hash in "[0-9a-f]{0,16}") {
        let _ = convert::template_from_json(&text, &hash);
        let _ = convert::task_from_json(&text, &hash);
    }
}
