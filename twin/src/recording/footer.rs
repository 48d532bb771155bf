//! The recording's footer in a fixed order. Rerun's encoder ends a file with a footer holding one
//! manifest per store (the run's recording and its layout), taken from a hash map, and each
//! manifest's schema lists the store's columns in a hash map's order too: both change from process
//! to process, so the same run would end in different bytes. The manifests are put in the order of
//! their store ids, each schema's columns in a fixed order (control, index, then data columns, each
//! by name; Rerun's own schema digest beside it does not depend on the order), and the footer is
//! written again in its place, with the stream footer's checksum renewed.

use std::fs::File;
use std::io::{Read, Seek, SeekFrom, Write};

use re_protos::common::v1alpha1::Schema;
use re_protos::external::prost::Message as _;
use re_protos::log_msg::v1alpha1::RrdFooter;
use rerun::external::arrow::datatypes::{Field, Schema as ArrowSchema};
use rerun::external::re_log_encoding::{
    Decodable, Encodable, MessageHeader, MessageKind, StreamFooter,
};

/// Orders the manifests of the footer at the end of `file` by store id.
pub(super) fn order_manifests(file: &mut File) -> Result<(), String> {
    let io = |err: std::io::Error| err.to_string();
    let size = StreamFooter::ENCODED_SIZE_BYTES as u64;
    let len = file.seek(SeekFrom::End(0)).map_err(io)?;
    let stream_footer_at = len
        .checked_sub(size)
        .ok_or("the recording ends before its footer")?;
    let mut tail = vec![0; size as usize];
    file.seek(SeekFrom::Start(stream_footer_at)).map_err(io)?;
    file.read_exact(&mut tail).map_err(io)?;
    let stream_footer = StreamFooter::from_rrd_bytes(&tail).map_err(|e| e.to_string())?;
    let [entry] = stream_footer.entries.as_slice() else {
        return Err("the recording's stream footer points at more than one footer".into());
    };
    let span = entry.rrd_footer_byte_span_from_start_excluding_header;
    let mut payload = vec![0; span.len as usize];
    file.seek(SeekFrom::Start(span.start)).map_err(io)?;
    file.read_exact(&mut payload).map_err(io)?;
    let mut footer = RrdFooter::decode(payload.as_slice()).map_err(|e| e.to_string())?;
    footer
        .manifests
        .sort_by_cached_key(|manifest| manifest.store_id.as_ref().map(|id| id.encode_to_vec()));
    for manifest in &mut footer.manifests {
        if let Some(schema) = &mut manifest.sorbet_schema {
            *schema = ordered_schema(schema)?;
        }
    }
    let mut ordered = Vec::with_capacity(payload.len());
    footer
        .to_rrd_bytes(&mut ordered)
        .map_err(|e| e.to_string())?;
    // A schema in another order may encode to another length: the footer's message header says
    // the new one, the stream footer follows the new footer, and the file ends there.
    let mut header = Vec::with_capacity(MessageHeader::ENCODED_SIZE_BYTES);
    MessageHeader {
        kind: MessageKind::End,
        len: ordered.len() as u64,
    }
    .to_rrd_bytes(&mut header)
    .map_err(|e| e.to_string())?;
    let header_at = span
        .start
        .checked_sub(header.len() as u64)
        .ok_or("the recording's footer has no message header")?;
    let mut renewed = Vec::with_capacity(tail.len());
    StreamFooter::from_rrd_footer_bytes(span.start, &ordered)
        .to_rrd_bytes(&mut renewed)
        .map_err(|e| e.to_string())?;
    file.seek(SeekFrom::Start(header_at)).map_err(io)?;
    file.write_all(&header).map_err(io)?;
    file.write_all(&ordered).map_err(io)?;
    file.write_all(&renewed).map_err(io)?;
    let end = span.start + (ordered.len() + renewed.len()) as u64;
    file.set_len(end).map_err(io)
}

/// The schema with its columns in a fixed order: control, index, then data columns, each by name.
fn ordered_schema(schema: &Schema) -> Result<Schema, String> {
    let arrow = ArrowSchema::try_from(schema).map_err(|e| e.to_string())?;
    let rank = |field: &Field| match field.metadata().get("rerun:kind").map(String::as_str) {
        Some("control") => 0,
        Some("index") => 1,
        _ => 2,
    };
    let mut fields: Vec<_> = arrow.fields().iter().cloned().collect();
    fields.sort_by(|a, b| (rank(a), a.name()).cmp(&(rank(b), b.name())));
    let ordered = ArrowSchema::new_with_metadata(fields, arrow.metadata().clone());
    Schema::try_from(&ordered).map_err(|e| e.to_string())
}
