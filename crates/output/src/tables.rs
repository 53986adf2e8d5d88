//! The per-step files of a run (trajectories, events, channel log, wire log) as CSV or Parquet,
//! streamed: Parquet rows are buffered in batches of [`BATCH`] and written as row groups
//! (zstd), so memory stays flat however long the run. The columns are the row type's fields in
//! both formats. A table may also be kept in memory as Arrow record batches ([`Table::memory`]:
//! what the Python package hands over), with the Parquet file's schema.
use crate::error::{OutputError, Result};
use crate::rundir::RunDir;
use arrow_array::RecordBatch;
use arrow_schema::FieldRef;
use parquet::arrow::ArrowWriter;
use parquet::basic::{Compression, ZstdLevel};
use parquet::file::properties::WriterProperties;
use serde::{de::DeserializeOwned, Serialize};
use serde_arrow::schema::{SchemaLike, TracingOptions};
use std::fs::File;
use std::io::BufWriter;
use std::sync::Arc;

/// Rows per Parquet row group.
pub const BATCH: usize = 65_536;

/// CSV or Parquet.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// Comma-separated text, one header line.
    Csv,
    /// Apache Parquet, zstd.
    Parquet,
}

impl Format {
    /// The format `[output] format` asks for, for the trajectory rows `scenario` will write.
    pub fn of(output: &platoon_config::OutputConfig, scenario: &platoon_sim::Scenario) -> Format {
        use platoon_config::OutputFormat;
        let rows = (scenario.steps + 1).div_ceil(output.decimate) * scenario.vehicles() as u64;
        match output.format {
            OutputFormat::Parquet => Format::Parquet,
            OutputFormat::Auto if rows >= platoon_config::AUTO_PARQUET_ROWS => Format::Parquet,
            OutputFormat::Auto | OutputFormat::Csv => Format::Csv,
        }
    }

    fn extension(self) -> &'static str {
        match self {
            Format::Csv => "csv",
            Format::Parquet => "parquet",
        }
    }
}

enum Sink<T> {
    Off,
    /// The writer, and the header to write should no row come (`None` once one came: serde
    /// wrote the header with it).
    Csv(Box<csv::Writer<BufWriter<File>>>, Option<Vec<String>>),
    /// Rows buffered into record batches of [`BATCH`], each written to `out` when full.
    Batches {
        fields: Vec<FieldRef>,
        rows: Vec<T>,
        out: BatchOut,
    },
}

/// Where full record batches go.
enum BatchOut {
    Parquet(Box<ArrowWriter<File>>),
    /// Kept for [`Table::take_batches`].
    Memory(Vec<RecordBatch>),
}

/// A table file being written (or not, when the run was told to skip it).
pub struct Table<T: Serialize + DeserializeOwned> {
    name: String,
    sink: Sink<T>,
}

/// The Arrow fields of `T` (unit enums as strings, options nullable).
pub fn fields<T: Serialize + DeserializeOwned>() -> Result<Vec<FieldRef>> {
    let options = TracingOptions::default()
        .enums_without_data_as_strings(true)
        .allow_null_fields(true);
    Vec::<FieldRef>::from_type::<T>(options)
        .map_err(|e| OutputError::table("", "deriving the Parquet schema", e))
}

/// [`fields`] without the columns `absent`.
fn fields_without<T: Serialize + DeserializeOwned>(absent: &[&str]) -> Result<Vec<FieldRef>> {
    let mut fields = fields::<T>()?;
    fields.retain(|f| !absent.contains(&f.name().as_str()));
    Ok(fields)
}

impl<T: Serialize + DeserializeOwned> Table<T> {
    /// Starts `<stem>.csv` or `<stem>.parquet` in `dir`; `enabled = false` writes nothing.
    pub fn create(dir: &RunDir, stem: &str, format: Format, enabled: bool) -> Result<Self> {
        Self::create_without(dir, stem, format, enabled, &[])
    }

    /// [`Table::create`] without the columns `absent`: fields of `T` its rows never serialize
    /// (`skip_serializing_if`), left out of the Parquet schema as the CSV leaves them out.
    pub fn create_without(
        dir: &RunDir,
        stem: &str,
        format: Format,
        enabled: bool,
        absent: &[&str],
    ) -> Result<Self> {
        let name = format!("{stem}.{}", format.extension());
        let sink = match (enabled, format) {
            (false, _) => Sink::Off,
            (true, Format::Csv) => {
                let header = fields_without::<T>(absent)?
                    .iter()
                    .map(|f| f.name().clone())
                    .collect();
                Sink::Csv(
                    Box::new(csv::Writer::from_writer(dir.writer(&name)?)),
                    Some(header),
                )
            }
            (true, Format::Parquet) => {
                let fields = fields_without::<T>(absent)?;
                let schema = Arc::new(arrow_schema::Schema::new(fields.clone()));
                let path = dir.path(&name);
                let file = File::create(&path).map_err(|e| {
                    OutputError::io(&path, format!("creating {}", path.display()), e)
                })?;
                let props = WriterProperties::builder()
                    .set_compression(Compression::ZSTD(ZstdLevel::default()))
                    // One row group per batch: the writer holds at most one batch encoded
                    // (its default, 1M rows, held ~60 MB for a 1000-vehicle run).
                    .set_max_row_group_row_count(Some(BATCH))
                    .build();
                let writer = ArrowWriter::try_new(file, schema, Some(props)).map_err(|e| {
                    OutputError::table(&path, format!("starting {}", path.display()), e)
                })?;
                Sink::Batches {
                    fields,
                    rows: Vec::with_capacity(BATCH),
                    out: BatchOut::Parquet(Box::new(writer)),
                }
            }
        };
        Ok(Self { name, sink })
    }

    /// A table kept in memory as record batches of at most [`BATCH`] rows ([`Table::take_batches`]);
    /// `enabled = false` keeps nothing. `stem` names it in errors.
    pub fn memory(stem: &str, enabled: bool) -> Result<Self> {
        Self::memory_without(stem, enabled, &[])
    }

    /// [`Table::memory`] without the columns `absent` (as [`Table::create_without`]).
    pub fn memory_without(stem: &str, enabled: bool, absent: &[&str]) -> Result<Self> {
        let sink = match enabled {
            false => Sink::Off,
            true => Sink::Batches {
                fields: fields_without::<T>(absent)?,
                rows: Vec::new(),
                out: BatchOut::Memory(Vec::new()),
            },
        };
        Ok(Self {
            name: stem.to_string(),
            sink,
        })
    }

    /// A table in memory: its schema and its batches so far (taken; call [`Table::finish`]
    /// first for the last rows). None for a table written to a file or not kept.
    pub fn take_batches(&mut self) -> Result<Option<(arrow_schema::SchemaRef, Vec<RecordBatch>)>> {
        match &mut self.sink {
            Sink::Batches {
                fields,
                out: BatchOut::Memory(batches),
                ..
            } => Ok(Some((
                Arc::new(arrow_schema::Schema::new(fields.clone())),
                std::mem::take(batches),
            ))),
            _ => Ok(None),
        }
    }

    /// Appends one row.
    pub fn write(&mut self, row: T) -> Result<()> {
        match &mut self.sink {
            Sink::Off => Ok(()),
            Sink::Csv(w, header) => {
                *header = None;
                w.serialize(row).map_err(|e| {
                    OutputError::table(&self.name, format!("writing {}", self.name), e)
                })
            }
            Sink::Batches { rows, .. } => {
                rows.push(row);
                if rows.len() >= BATCH {
                    self.flush_batch()?;
                }
                Ok(())
            }
        }
    }

    fn flush_batch(&mut self) -> Result<()> {
        if let Sink::Batches { fields, rows, out } = &mut self.sink {
            if !rows.is_empty() {
                let batch = serde_arrow::to_record_batch(fields, rows).map_err(|e| {
                    OutputError::table(&self.name, format!("converting rows for {}", self.name), e)
                })?;
                match out {
                    BatchOut::Parquet(writer) => writer.write(&batch).map_err(|e| {
                        OutputError::table(&self.name, format!("writing {}", self.name), e)
                    })?,
                    BatchOut::Memory(batches) => batches.push(batch),
                }
                rows.clear();
            }
        }
        Ok(())
    }

    /// Writes what is buffered and closes the file.
    pub fn finish(&mut self) -> Result<()> {
        self.flush_batch()?;
        if let Sink::Batches {
            out: BatchOut::Memory(_),
            ..
        } = self.sink
        {
            return Ok(()); // kept for take_batches
        }
        match std::mem::replace(&mut self.sink, Sink::Off) {
            Sink::Off => Ok(()),
            Sink::Csv(mut w, header) => {
                // A table without rows still has its header.
                if let Some(header) = header {
                    w.write_record(&header).map_err(|e| {
                        OutputError::table(&self.name, format!("writing {}", self.name), e)
                    })?;
                }
                w.flush().map_err(|e| {
                    OutputError::table(&self.name, format!("writing {}", self.name), e)
                })
            }
            Sink::Batches { out, .. } => match out {
                BatchOut::Parquet(writer) => writer.close().map(|_| ()).map_err(|e| {
                    OutputError::table(&self.name, format!("closing {}", self.name), e)
                }),
                BatchOut::Memory(_) => Ok(()),
            },
        }
    }
}

/// Reads a Parquet file written by [`Table`] back into rows.
#[cfg(test)]
pub fn read_parquet<T: Serialize + DeserializeOwned>(path: &std::path::Path) -> Result<Vec<T>> {
    let mut out = Vec::new();
    read_rows::<_, OutputError>(path, |r| {
        out.push(r);
        Ok(())
    })?;
    Ok(out)
}

/// A table file written by [`Table`] (CSV or Parquet) as record batches of at most [`BATCH`]
/// rows with the schema of [`fields`]: its rows are read and converted, so both formats give
/// the same batches.
/// Of the columns `optional` (see [`Table::create_without`]), only those the file has are in
/// the schema.
pub fn read_batches<T: Serialize + DeserializeOwned>(
    path: &std::path::Path,
    optional: &[&str],
) -> Result<(arrow_schema::SchemaRef, Vec<RecordBatch>)> {
    let mut fields = fields::<T>()?;
    if !optional.is_empty() {
        let columns = columns(path)?;
        fields.retain(|f| {
            !optional.contains(&f.name().as_str()) || columns.iter().any(|c| c == f.name())
        });
    }
    let schema = Arc::new(arrow_schema::Schema::new(fields.clone()));
    let mut batches = Vec::new();
    let mut rows: Vec<T> = Vec::new();
    let convert = |rows: &mut Vec<T>, batches: &mut Vec<RecordBatch>| -> Result<()> {
        if !rows.is_empty() {
            batches
                .push(serde_arrow::to_record_batch(&fields, rows).map_err(|e| reading(path, e))?);
            rows.clear();
        }
        Ok(())
    };
    read_rows::<_, OutputError>(path, |row: T| {
        rows.push(row);
        if rows.len() >= BATCH {
            convert(&mut rows, &mut batches)?;
        }
        Ok(())
    })?;
    convert(&mut rows, &mut batches)?;
    Ok((schema, batches))
}

/// Streams the rows of a table file written by [`Table`] (`.csv` or `.parquet`, by its
/// extension) to `each`, in file order, a Parquet row group at a time. The first error,
/// the file's ([`OutputError`], converted into `E`) or `each`'s, stops the reading.
pub fn read_rows<T: DeserializeOwned, E: From<OutputError>>(
    path: &std::path::Path,
    mut each: impl FnMut(T) -> Result<(), E>,
) -> Result<(), E> {
    let file = File::open(path)
        .map_err(|e| OutputError::io(path, format!("opening {}", path.display()), e))?;
    if path.extension().is_some_and(|e| e == "parquet") {
        let reader = parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(file)
            .and_then(|b| b.build())
            .map_err(|e| reading(path, e))?;
        for batch in reader {
            let batch = batch.map_err(|e| reading(path, e))?;
            let rows =
                serde_arrow::from_record_batch::<Vec<T>>(&batch).map_err(|e| reading(path, e))?;
            rows.into_iter().try_for_each(&mut each)?;
        }
    } else {
        let mut csv = csv::Reader::from_reader(std::io::BufReader::new(file));
        for (line, row) in csv.deserialize().enumerate() {
            let row = row.map_err(|e| {
                OutputError::table(path, format!("{}: row {}", path.display(), line + 1), e)
            })?;
            each(row)?;
        }
    }
    Ok(())
}

/// The column names of a table file written by [`Table`] (`.csv` or `.parquet`).
fn columns(path: &std::path::Path) -> Result<Vec<String>> {
    let file = File::open(path)
        .map_err(|e| OutputError::io(path, format!("opening {}", path.display()), e))?;
    if path.extension().is_some_and(|e| e == "parquet") {
        let builder = parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(file)
            .map_err(|e| reading(path, e))?;
        Ok(builder
            .schema()
            .fields()
            .iter()
            .map(|f| f.name().clone())
            .collect())
    } else {
        let mut csv = csv::Reader::from_reader(std::io::BufReader::new(file));
        let headers = csv.headers().map_err(|e| reading(path, e))?;
        Ok(headers.iter().map(str::to_string).collect())
    }
}

/// A malformed table file: `reading <path>` and why.
fn reading(
    path: &std::path::Path,
    e: impl Into<Box<dyn std::error::Error + Send + Sync>>,
) -> OutputError {
    OutputError::table(path, format!("reading {}", path.display()), e)
}

#[cfg(test)]
mod tests {
    use super::*;
    use platoon_sim::StepRow;

    #[test]
    fn parquet_holds_the_rows_and_the_columns_of_the_csv() {
        let (_, scenario) = platoon_config::parse(
            // 140 s: 14 001 steps of 5 vehicles, just over one row group (BATCH rows).
            &platoon_config::PAPER_TOML.replace("duration_s = 55.0", "duration_s = 140.0"),
            std::path::Path::new("paper.toml"),
        )
        .unwrap();
        let mut rows = Vec::new();
        platoon_sim::run(scenario, |r| rows.extend_from_slice(r)).unwrap();
        assert!(rows.len() > BATCH, "several row groups");
        // Without the radar's columns (a run without traffic), and with them.
        for radar in [false, true] {
            let rows: Vec<StepRow> = rows.iter().map(|r| r.with_radar_columns(radar)).collect();
            the_same_in_both_formats(&rows, radar);
        }
    }

    #[test]
    fn a_csv_without_rows_has_its_header_and_reads_back_empty() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = RunDir::create(&tmp.path().join("r"), false).unwrap();
        let absent = [StepRow::HEAD_COLUMN, StepRow::LANE_COLUMN];
        let mut t =
            Table::<StepRow>::create_without(&dir, "empty", Format::Csv, true, &absent).unwrap();
        t.finish().unwrap();
        let text = std::fs::read_to_string(dir.path("empty.csv")).unwrap();
        let columns: Vec<String> = fields::<StepRow>()
            .unwrap()
            .iter()
            .map(|f| f.name().clone())
            .filter(|f| !absent.contains(&f.as_str()))
            .collect();
        assert_eq!(text, format!("{}\n", columns.join(",")));
        let (_, batches) = read_batches::<StepRow>(&dir.path("empty.csv"), &[]).unwrap();
        assert!(batches.is_empty());
        // The injector node writes the channel log's header itself: the same columns.
        use platoon_attacks::channel::ChannelEvent;
        let names: Vec<String> = fields::<ChannelEvent>()
            .unwrap()
            .iter()
            .map(|f| f.name().clone())
            .collect();
        assert_eq!(names, ChannelEvent::COLUMNS);
    }

    fn the_same_in_both_formats(rows: &[StepRow], radar: bool) {
        // The paper's scenario never splits nor changes lanes: no head or lane column.
        let mut absent = vec![StepRow::HEAD_COLUMN, StepRow::LANE_COLUMN];
        if !radar {
            absent.extend(StepRow::RADAR_COLUMNS);
        }
        let absent = &absent[..];
        let tmp = tempfile::tempdir().unwrap();
        let dir = RunDir::create(&tmp.path().join("r"), false).unwrap();
        for format in [Format::Csv, Format::Parquet] {
            let mut t =
                Table::<StepRow>::create_without(&dir, "trajectories", format, true, absent)
                    .unwrap();
            for r in rows {
                t.write(*r).unwrap();
            }
            t.finish().unwrap();
        }
        let back: Vec<StepRow> = read_parquet(&dir.path("trajectories.parquet")).unwrap();
        // NaN (the leader's theta) compares unequal: compare through JSON, where it is null.
        // A radar that saw nothing is no value in the file, read back as no target.
        let json = |r: &[StepRow]| {
            let r: Vec<StepRow> = r.iter().map(|r| r.with_radar_columns(radar)).collect();
            serde_json::to_string(&r).unwrap()
        };
        assert_eq!(json(&back), json(rows));
        let mut csv = csv::Reader::from_path(dir.path("trajectories.csv")).unwrap();
        let header: Vec<String> = csv.headers().unwrap().iter().map(String::from).collect();
        let columns: Vec<String> = fields::<StepRow>()
            .unwrap()
            .iter()
            .map(|f| f.name().clone())
            .filter(|f| !absent.contains(&f.as_str()))
            .collect();
        assert_eq!(header, columns);
        assert_eq!(
            header.iter().any(|h| h == "radar_target"),
            radar,
            "{header:?}"
        );
        // In memory: the same rows, in batches of BATCH, and read back from either file alike.
        let mut t = Table::<StepRow>::memory_without("trajectories", true, absent).unwrap();
        for r in rows {
            t.write(*r).unwrap();
        }
        t.finish().unwrap();
        let (schema, batches) = t.take_batches().unwrap().unwrap();
        assert_eq!(batches.len(), rows.len().div_ceil(BATCH));
        assert!(batches.iter().all(|b| b.schema() == schema));
        let mut kept: Vec<StepRow> = Vec::new();
        for b in &batches {
            kept.extend(serde_arrow::from_record_batch::<Vec<StepRow>>(b).unwrap());
        }
        assert_eq!(json(&kept), json(rows));
        for file in ["trajectories.csv", "trajectories.parquet"] {
            let (s, b) =
                read_batches::<StepRow>(&dir.path(file), &StepRow::OPTIONAL_COLUMNS).unwrap();
            assert_eq!((s, b), (schema.clone(), batches.clone()), "{file}");
        }
        assert!(Table::<StepRow>::memory("off", false)
            .unwrap()
            .take_batches()
            .unwrap()
            .is_none());
    }
}
