"""Every file format: tank records, ship files and hull files."""

from ._hull_file import (
    load_hull as load_hull,
    loading_from_dict as loading_from_dict,
    read_hull_file as read_hull_file,
)
from ._records import (
    Record as Record,
    RecordError as RecordError,
    group_by_sea_state as group_by_sea_state,
    load_record as load_record,
    load_records as load_records,
    make_record as make_record,
    record_to_text as record_to_text,
    save_record as save_record,
)
from ._ship_file import (
    load_ship as load_ship,
    ship_from_dict as ship_from_dict,
    ship_to_dict as ship_to_dict,
    ship_to_toml as ship_to_toml,
)
