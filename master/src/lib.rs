//! hevo's master: the experiment files, the evolutionary algorithm, the scheduler that hands
//! batches of genome evaluations to workers (in-process threads or remote gRPC workers), the
//! resumable run driver, the service, and the library behind every `hevo` subcommand.

pub mod viz;
