//! What a submission may not do: ask for more than the limits allow (refused with the field
//! named, before anything is allocated), use node names that are not plain identifiers, get a
//! huge input quoted back at it, send bytes that are not a protobuf message, make a second
//! job by retrying, or reuse a retry's request id for another submission.

use hevo_proto::v1;
use hevo_tests::Scratch;
use hevo_tests::service::{CLIENT_TOKEN, SMALL, jobs, master_with_roles, runtime, submission};

fn refusal(url: &str, request: v1::SubmitJobRequest) -> tonic::Status {
    runtime().block_on(async {
        jobs(url, CLIENT_TOKEN)
            .submit_job(request)
            .await
            .unwrap_err()
    })
}

#[test]
fn oversized_jobs_and_bad_names_are_refused_naming_the_field() {
    let scratch = Scratch::new("limits");
    let master = master_with_roles(&scratch, &[]);
    for (edit, field) in [
        (
            SMALL.replace("population = 6", "population = 4000000"),
            "population",
        ),
        (
            SMALL.replace(
                "samples = 2\ngenerations",
                "samples = 4000000000\ngenerations",
            ),
            "samples",
        ),
        (
            SMALL.replace("name = \"follow_wall\"", "name = \"..\""),
            "node[0].name",
        ),
        (
            SMALL.replace("name = \"follow_wall\"", "name = \".\""),
            "node[0].name",
        ),
        (
            SMALL.replace("name = \"follow_wall\"", "name = \"a\\u0000b\""),
            "node[0].name",
        ),
        (
            SMALL.replace(
                "name = \"follow_wall\"",
                &format!("name = \"{}\"", "n".repeat(300)),
            ),
            "node[0].name",
        ),
    ] {
        let status = refusal(&master.url, submission(&edit));
        assert_eq!(status.code(), tonic::Code::InvalidArgument, "{status:?}");
        assert!(
            status.message().contains(field) && status.message().len() < 2000,
            "{field}: {}",
            status.message()
        );
    }
    let mut request = submission(SMALL);
    request.runs = Some(0);
    let status = refusal(&master.url, request);
    assert!(status.message().starts_with("runs:"), "{status:?}");
    let mut request = submission(SMALL);
    request.request_id = "r".repeat(65);
    let status = refusal(&master.url, request);
    assert_eq!(status.code(), tonic::Code::InvalidArgument, "{status:?}");
    assert!(status.message().starts_with("request_id:"), "{status:?}");
}

/// Within every other limit, a generation of 100,000 genomes of a million genes each (a
/// master once accepted it and ran out of memory, again on every restart).
#[test]
fn a_generation_too_large_for_memory_is_refused_and_the_master_lives_on() {
    let scratch = Scratch::new("limits-memory");
    let master = master_with_roles(&scratch, &[]);
    let huge = SMALL
        .replace("population = 6", "population = 100000")
        .replace("elites = 2", "elites = 1")
        .replace(
            "inputs = [\"ir\"]",
            "inputs = [\"ir\", \"light\", \"near_robot\"]",
        )
        .replace("hidden = 2", "hidden = 1000");
    let status = refusal(&master.url, submission(&huge));
    assert_eq!(status.code(), tonic::Code::InvalidArgument, "{status:?}");
    assert!(
        status.message().contains("node[0].evolution.population")
            && status.message().contains("1011002 genes")
            && status.message().contains("at most 1024 MiB"),
        "{}",
        status.message()
    );
    runtime().block_on(async {
        let listed = jobs(&master.url, CLIENT_TOKEN)
            .list_jobs(v1::ListJobsRequest {})
            .await
            .expect("the master still answers")
            .into_inner();
        assert!(listed.jobs.is_empty());
    });
}

#[test]
fn a_huge_line_is_quoted_only_in_part() {
    let scratch = Scratch::new("limits-quote");
    let master = master_with_roles(&scratch, &[]);
    let long = format!("{SMALL}\nbroken = \"{}\" x\n", "a".repeat(16_000));
    let status = refusal(&master.url, submission(&long));
    assert_eq!(status.code(), tonic::Code::InvalidArgument, "{status:?}");
    assert!(
        status.message().len() < 2000,
        "{} characters",
        status.message().len()
    );
    assert!(
        status.message().contains('^'),
        "the caret stays: {}",
        status.message()
    );
}

#[test]
fn a_retried_submission_returns_the_same_job() {
    let scratch = Scratch::new("limits-retry");
    let master = master_with_roles(&scratch, &[]);
    runtime().block_on(async {
        let mut client = jobs(&master.url, CLIENT_TOKEN);
        let mut request = submission(SMALL);
        request.request_id = "4d2c0a4e-0000-4000-8000-000000000001".into();
        let first = client
            .submit_job(request.clone())
            .await
            .unwrap()
            .into_inner()
            .job_id;
        let again = client
            .submit_job(request.clone())
            .await
            .unwrap()
            .into_inner()
            .job_id;
        assert_eq!(first, again);
        request.request_id = "4d2c0a4e-0000-4000-8000-000000000002".into();
        let other = client
            .submit_job(request)
            .await
            .unwrap()
            .into_inner()
            .job_id;
        assert_ne!(first, other);
        // The same id with another experiment is refused, not answered with the first job.
        let mut reused = submission(&SMALL.replace("seed = 3", "seed = 4"));
        reused.request_id = "4d2c0a4e-0000-4000-8000-000000000001".into();
        let status = client.submit_job(reused).await.unwrap_err();
        assert_eq!(status.code(), tonic::Code::InvalidArgument, "{status:?}");
        assert!(
            status.message().starts_with("request_id:")
                && status.message().contains("another submission")
                && status.message().contains(&first),
            "{}",
            status.message()
        );
        let listed = client
            .list_jobs(v1::ListJobsRequest {})
            .await
            .unwrap()
            .into_inner();
        assert_eq!(listed.jobs.len(), 2);
    });
}

#[test]
fn bytes_that_are_no_message_are_invalid_argument() {
    let scratch = Scratch::new("limits-malformed");
    let master = master_with_roles(&scratch, &[]);
    let status = runtime().block_on(async {
        let channel = hevo_proto::client::ClientOptions {
            url: master.url.clone(),
            token: Some(CLIENT_TOKEN.into()),
            tls_ca: None,
        }
        .connect()
        .await
        .unwrap();
        let mut grpc = tonic::client::Grpc::new(channel);
        grpc.ready().await.unwrap();
        // Field 1 (a string) with a length far beyond the message: not a protobuf message.
        let garbage: Vec<u8> = vec![0x0A, 0xFF, 0xFF, 0xFF, 0x0F, 0x01];
        grpc.unary(
            tonic::Request::new(garbage),
            http::uri::PathAndQuery::from_static("/hevo.v1.JobService/SubmitJob"),
            RawCodec,
        )
        .await
        .unwrap_err()
    });
    assert_eq!(status.code(), tonic::Code::InvalidArgument, "{status:?}");
}

/// Sends bytes as they are, and reads the answer's bytes.
#[derive(Debug, Clone, Default)]
struct RawCodec;

impl tonic::codec::Codec for RawCodec {
    type Encode = Vec<u8>;
    type Decode = Vec<u8>;
    type Encoder = RawCodec;
    type Decoder = RawCodec;
    fn encoder(&mut self) -> RawCodec {
        RawCodec
    }
    fn decoder(&mut self) -> RawCodec {
        RawCodec
    }
}

impl tonic::codec::Encoder for RawCodec {
    type Item = Vec<u8>;
    type Error = tonic::Status;
    fn encode(
        &mut self,
        item: Vec<u8>,
        dst: &mut tonic::codec::EncodeBuf<'_>,
    ) -> Result<(), tonic::Status> {
        use bytes::BufMut;
        dst.put_slice(&item);
        Ok(())
    }
}

impl tonic::codec::Decoder for RawCodec {
    type Item = Vec<u8>;
    type Error = tonic::Status;
    fn decode(
        &mut self,
        src: &mut tonic::codec::DecodeBuf<'_>,
    ) -> Result<Option<Vec<u8>>, tonic::Status> {
        use bytes::Buf;
        let mut out = vec![0; src.remaining()];
        src.copy_to_slice(&mut out);
        Ok(Some(out))
    }
}
