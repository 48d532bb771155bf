//! Units as OPC UA `EUInformation` (Part 8, 5.6.3): a variable's `EngineeringUnits` property
//! from the UNECE common code of its SI unit, for the served twin's and the shadow's variables.

use opcua::server::address_space::{AddressSpace, VariableBuilder};
use opcua::types::{
    DataTypeId, EUInformation, ExtensionObject, LocalizedText, NodeId, QualifiedName,
    VariableTypeId, Variant,
};

/// The UNECE units namespace of EUInformation (OPC UA Part 8).
const UNECE_NAMESPACE: &str = "http://www.opcfoundation.org/UA/units/un/cefact";

/// Adds variable `id`'s `EngineeringUnits` property (node `<path>/EngineeringUnits`) when
/// `unit` has a UNECE code; a unit without one (`deg`, text) gets none.
pub fn add_engineering_units(space: &mut AddressSpace, id: &NodeId, path: &str, unit: &str) {
    let Some(units) = eu_information(unit) else {
        return;
    };
    let property = NodeId::new(id.namespace, format!("{path}/EngineeringUnits"));
    VariableBuilder::new(
        &property,
        QualifiedName::new(0, "EngineeringUnits"),
        "EngineeringUnits",
    )
    .data_type(DataTypeId::EUInformation)
    .value(Variant::ExtensionObject(ExtensionObject::from_message(
        units,
    )))
    .has_type_definition(VariableTypeId::PropertyType)
    .property_of(id.clone())
    .insert(space);
}

/// The UNECE common code of the twin's units that have one.
fn unece_code(unit: &str) -> Option<&'static str> {
    Some(match unit {
        "m" => "MTR",
        "rad" => "C81",
        "N" => "NEW",
        "N·m" | "N*m" | "N m" => "NU",
        "m/s" => "MTS",
        "rad/s" => "2A",
        "s" => "SEC",
        "kg" => "KGM",
        "A" => "AMP",
        "1" => "C62",
        _ => return None,
    })
}

/// `unit` as EUInformation (OPC UA Part 8, 5.6.3), if it has a UNECE code.
pub fn eu_information(unit: &str) -> Option<EUInformation> {
    let code = unece_code(unit)?;
    Some(EUInformation {
        namespace_uri: UNECE_NAMESPACE.into(),
        unit_id: unit_id(code),
        display_name: LocalizedText::new("en", unit),
        description: LocalizedText::new("en", code),
    })
}

/// The UnitId of a UNECE common code: its ASCII bytes, big-endian (Part 8's algorithm).
fn unit_id(code: &str) -> i32 {
    code.bytes().fold(0, |id, c| (id << 8) | i32::from(c))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_ids_follow_part_8() {
        // Part 8's examples: "MTR" → 5067858, "C81" → 4405297.
        assert_eq!(unit_id("MTR"), 5_067_858);
        assert_eq!(unit_id("C81"), 4_405_297);
        assert_eq!(unit_id("2A"), 0x3241);
        assert!(eu_information("deg").is_none());
        assert_eq!(
            eu_information("N·m").map(|e| e.unit_id),
            Some(unit_id("NU"))
        );
    }
}
