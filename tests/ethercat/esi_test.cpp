// The ESI reader (protocol/ethercat/esi.hpp): a small hand-written ESI with the parts a
// conformance check reads, and malformed files, each refused with file:line.
#include "protocol/ethercat/esi.hpp"

#include <gtest/gtest.h>

#include <string>

namespace drivecheck::ethercat {
namespace {

// Line numbers matter below: keep the layout.
constexpr const char* kGood = R"(<?xml version="1.0"?>
<EtherCATInfo Version="1.6">
  <Vendor><Id>#x0000001D</Id><Name>Example</Name></Vendor>
  <Descriptions>
    <Devices>
      <Device Physics="YY">
        <Type ProductCode="#x00001234" RevisionNo="65538">CMMP</Type>
        <Name LcId="1033">Motor controller</Name>
        <Profile>
          <Dictionary>
            <DataTypes>
              <DataType><Name>DT1C12ARR</Name><BaseType>UINT</BaseType><BitSize>32</BitSize>
                <ArrayInfo><LBound>1</LBound><Elements>2</Elements></ArrayInfo></DataType>
              <DataType><Name>DT1C12</Name><BitSize>48</BitSize>
                <SubItem><SubIdx>0</SubIdx><Name>count</Name><Type>USINT</Type><BitSize>8</BitSize><Flags><Access WriteRestrictions="PreOP">rw</Access></Flags></SubItem>
                <SubItem><Name>Elements</Name><Type>DT1C12ARR</Type><BitSize>32</BitSize><Flags><Access>rw</Access></Flags></SubItem>
              </DataType>
              <DataType><Name>UINT</Name><BitSize>16</BitSize></DataType>
            </DataTypes>
            <Objects>
              <Object><Index>#x1000</Index><Name>Device type</Name><Type>UDINT</Type><BitSize>32</BitSize>
                <Info><DefaultData>92010200</DefaultData></Info><Flags><Access>ro</Access></Flags></Object>
              <Object><Index>#x1C12</Index><Name>RxPDO assign</Name><Type>DT1C12</Type><BitSize>48</BitSize>
                <Info>
                  <SubItem><Name>count</Name><Info><DefaultData>01</DefaultData></Info></SubItem>
                  <SubItem><Name>Elements 1</Name><Info><DefaultData>0016</DefaultData></Info></SubItem>
                </Info></Object>
              <Object><Index>4097</Index><Name>decimal index</Name><Type>USINT</Type><BitSize>8</BitSize><Flags><Access>wo</Access></Flags></Object>
            </Objects>
          </Dictionary>
        </Profile>
        <Sm DefaultSize="128" StartAddress="#x1000" ControlByte="#x26" Enable="1">MBoxOut</Sm>
        <Sm StartAddress="#x1100" ControlByte="#x64" Enable="1">Outputs</Sm>
        <RxPdo Sm="2" Fixed="1" Mandatory="true"><Index>#x1600</Index><Name>RxPDO 1</Name>
          <Entry><Index>#x6040</Index><SubIndex>0</SubIndex><BitLen>16</BitLen><Name>Controlword</Name><DataType>UINT</DataType></Entry>
          <Entry><Index>0</Index><BitLen>8</BitLen></Entry>
        </RxPdo>
        <RxPdo><Index>#x1601</Index><Name>RxPDO 2</Name></RxPdo>
        <TxPdo Sm="3"><Index>#x1A00</Index><Entry><Index>#x6041</Index><SubIndex>#x0</SubIndex><BitLen>16</BitLen></Entry></TxPdo>
        <Mailbox><CoE SdoInfo="true" PdoAssign="1" CompleteAccess="false"/></Mailbox>
      </Device>
    </Devices>
  </Descriptions>
</EtherCATInfo>
)";

TEST(EsiReader, ReadsIdentityMailboxAndSyncManagers) {
  // Given a small ESI, When it is read, Then the vendor, the device's identity, CoE and SMs
  const auto esi = read_esi(kGood, "good.xml");
  ASSERT_TRUE(esi) << esi.error().to_string();
  EXPECT_EQ(esi->vendor_id, 0x1Du);
  ASSERT_EQ(esi->devices.size(), 1u);
  const EsiDevice& d = esi->devices[0];
  EXPECT_EQ(d.product_code, 0x1234u);
  EXPECT_EQ(d.revision_number, 65538u);
  EXPECT_EQ(d.name, "Motor controller");
  EXPECT_EQ(d.line, 6);
  ASSERT_TRUE(d.coe);
  EXPECT_TRUE(d.coe->sdo_info);
  EXPECT_TRUE(d.coe->pdo_assign);
  EXPECT_FALSE(d.coe->pdo_config);
  EXPECT_FALSE(d.coe->complete_access);
  ASSERT_EQ(d.sync_managers.size(), 2u);
  EXPECT_EQ(d.sync_managers[0].type, "MBoxOut");
  EXPECT_EQ(d.sync_managers[0].start_address, 0x1000);
  EXPECT_EQ(d.sync_managers[0].default_size, 128);
  EXPECT_EQ(d.sync_managers[0].control_byte, 0x26);
  EXPECT_TRUE(d.sync_managers[0].enable);
  EXPECT_FALSE(d.sync_managers[1].default_size);
}

TEST(EsiReader, ReadsPdosWithTheirDefaultAssignment) {
  // Given the ESI, When its PDOs are read, Then entries, gaps, flags and the @Sm assignment
  const auto esi = read_esi(kGood, "good.xml");
  ASSERT_TRUE(esi) << esi.error().to_string();
  const EsiDevice& d = esi->devices[0];
  ASSERT_EQ(d.rx_pdos.size(), 2u);
  EXPECT_EQ(d.rx_pdos[0].index, 0x1600);
  EXPECT_EQ(d.rx_pdos[0].sm, 2);
  EXPECT_TRUE(d.rx_pdos[0].fixed);
  EXPECT_TRUE(d.rx_pdos[0].mandatory);
  ASSERT_EQ(d.rx_pdos[0].entries.size(), 2u);
  EXPECT_EQ(d.rx_pdos[0].entries[0].mapping_value(), 0x60400010u);
  EXPECT_EQ(d.rx_pdos[0].entries[1].mapping_value(), 0x00000008u);
  EXPECT_FALSE(d.rx_pdos[1].sm);
  ASSERT_EQ(d.default_rx_assignment().size(), 1u);
  ASSERT_EQ(d.default_tx_assignment().size(), 1u);
  EXPECT_EQ(d.default_tx_assignment()[0]->entries[0].mapping_value(), 0x60410010u);
}

TEST(EsiReader, ReadsObjectsWithAccessAndDefaults) {
  // Given the ESI's dictionary, When it is read, Then VARs, a structured object whose array
  // elements come from ArrayInfo, the defaults (by name) and the access
  const auto esi = read_esi(kGood, "good.xml");
  ASSERT_TRUE(esi) << esi.error().to_string();
  const EsiDevice& d = esi->devices[0];
  ASSERT_EQ(d.objects.size(), 3u);
  const EsiSubItem* type = d.find(0x1000, 0);
  ASSERT_NE(type, nullptr);
  EXPECT_EQ(type->access, EsiAccess::ro);
  EXPECT_EQ(type->default_data, (std::vector<std::uint8_t>{0x92, 0x01, 0x02, 0x00}));
  const EsiObject* assign = d.find(0x1C12);
  ASSERT_NE(assign, nullptr);
  EXPECT_TRUE(assign->structured);
  ASSERT_EQ(assign->entries.size(), 3u);
  EXPECT_EQ(assign->entries[0].write_restrictions, "PreOP");
  EXPECT_EQ(assign->entries[1].sub_index, 1);
  EXPECT_EQ(assign->entries[2].sub_index, 2);
  EXPECT_EQ(assign->entries[2].bit_size, 16u);
  EXPECT_EQ(d.find(0x1C12, 1)->default_data, (std::vector<std::uint8_t>{0x00, 0x16}));
  EXPECT_FALSE(d.find(0x1C12, 2)->default_data);
  EXPECT_EQ(d.find(0x1000)->line, 21);
  EXPECT_EQ(d.find(4097, 0)->access, EsiAccess::wo);
}

// The error of reading `text`, "" when it reads.
std::string error_of(const std::string& text) {
  const auto esi = read_esi(text, "bad.xml");
  return esi ? std::string() : esi.error().to_string();
}

std::string with(std::string_view from, std::string_view to) {
  std::string text = kGood;
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

TEST(EsiReader, RefusesMalformedXmlWithItsLine) {
  // Given an ESI with an unclosed element on line 7, When it is read, Then the error names
  // bad.xml and a line at or after the damage (the parser stops where it notices)
  const std::string error = error_of(with("CMMP</Type>", "CMMP</Typo>"));
  EXPECT_NE(error.find("bad.xml:7: not well-formed XML"), std::string::npos) << error;
}

TEST(EsiReader, RefusesBadNumbersWithTheElementsLine) {
  // Given a product code and an object index that are no numbers, When read, Then each error
  // names the line of its element
  EXPECT_NE(error_of(with("#x00001234", "#xZZ")).find("bad.xml:7: Type@ProductCode '#xZZ'"),
            std::string::npos)
      << error_of(with("#x00001234", "#xZZ"));
  EXPECT_NE(error_of(with("<Index>#x1000</Index>", "<Index>#x10000</Index>"))
                .find("bad.xml:21: <Index> '#x10000' is out of range"),
            std::string::npos)
      << error_of(with("<Index>#x1000</Index>", "<Index>#x10000</Index>"));
}

TEST(EsiReader, RefusesWhatItCannotJudge) {
  // Given ESIs with a bad access, an odd DefaultData, a SubItem without SubIdx of a non-array
  // type, a duplicate object, no vendor, and no device, When read, Then each is a named error
  EXPECT_NE(error_of(with("<Access>ro</Access>", "<Access>readonly</Access>"))
                .find("bad.xml:22: <Access> 'readonly' is none of ro, rw, wo"),
            std::string::npos);
  EXPECT_NE(error_of(with("92010200", "9201020")).find("bad.xml:22: <DefaultData> '9201020'"),
            std::string::npos);
  EXPECT_NE(error_of(with("<Type>DT1C12ARR</Type>", "<Type>UINT</Type>"))
                .find("bad.xml:16: <SubItem> 'Elements' has no <SubIdx>"),
            std::string::npos);
  EXPECT_NE(error_of(with("<Index>4097</Index>", "<Index>#x1000</Index>"))
                .find("bad.xml:28: <Object> 1000h is there twice"),
            std::string::npos);
  EXPECT_NE(error_of(with("<Vendor><Id>#x0000001D</Id><Name>Example</Name></Vendor>", ""))
                .find("bad.xml:2: <EtherCATInfo> has no <Vendor>"),
            std::string::npos);
  EXPECT_NE(error_of("<EtherCATInfo><Vendor><Id>1</Id></Vendor></EtherCATInfo>")
                .find("describes no device"),
            std::string::npos);
  EXPECT_NE(error_of("<EDS/>").find("bad.xml:1: no <EtherCATInfo> root element"),
            std::string::npos);
  EXPECT_NE(error_of("").find("bad.xml"), std::string::npos);
}

TEST(EsiReader, FindsTheDeviceBySlaveIdentity) {
  // Given the ESI, When the device of a slave is looked up, Then by product code (revision
  // preferred), nothing for another product
  const auto esi = read_esi(kGood, "good.xml");
  ASSERT_TRUE(esi);
  EXPECT_EQ(find_esi_device(*esi, 0x1234, 65538), &esi->devices[0]);
  EXPECT_EQ(find_esi_device(*esi, 0x1234, 1), &esi->devices[0]);
  EXPECT_EQ(find_esi_device(*esi, 0x9999, 65538), nullptr);
  EXPECT_EQ(find_esi_device(*esi, std::nullopt, std::nullopt), &esi->devices[0]);
}

// PdoMapping flags, Dc/OpMode, Slots and Modules. Line numbers matter below: keep the layout.
constexpr const char* kModular = R"(<?xml version="1.0"?>
<EtherCATInfo Version="1.6">
  <Vendor><Id>2</Id><Name>Example</Name></Vendor>
  <Descriptions>
    <Devices>
      <Device Physics="YY">
        <Type ProductCode="#x7" RevisionNo="1">Coupler</Type>
        <Name>Modular drive</Name>
        <Profile>
          <Dictionary>
            <DataTypes>
              <DataType><Name>DT7000</Name><BitSize>48</BitSize>
                <SubItem><SubIdx>0</SubIdx><Name>count</Name><Type>USINT</Type><BitSize>8</BitSize><Flags><Access>ro</Access></Flags></SubItem>
                <SubItem><SubIdx>1</SubIdx><Name>Out</Name><Type>UINT</Type><BitSize>16</BitSize><Flags><Access>rw</Access><PdoMapping>R</PdoMapping></Flags></SubItem>
                <SubItem><SubIdx>2</SubIdx><Name>Both</Name><Type>UINT</Type><BitSize>16</BitSize><Flags><Access>rw</Access></Flags></SubItem>
              </DataType>
            </DataTypes>
            <Objects>
              <Object><Index>#x6041</Index><Name>Statusword</Name><Type>UINT</Type><BitSize>16</BitSize><Flags><Access>ro</Access><PdoMapping>T</PdoMapping></Flags></Object>
              <Object><Index>#x6040</Index><Name>Controlword</Name><Type>UINT</Type><BitSize>16</BitSize><Flags><Access>rw</Access><PdoMapping>rt</PdoMapping></Flags></Object>
              <Object><Index>#x7000</Index><Name>Record</Name><Type>DT7000</Type><BitSize>48</BitSize><Flags><PdoMapping>TR</PdoMapping></Flags></Object>
              <Object><Index>#x1000</Index><Name>Device type</Name><Type>UDINT</Type><BitSize>32</BitSize><Flags><Access>ro</Access></Flags></Object>
            </Objects>
          </Dictionary>
        </Profile>
        <Dc>
          <OpMode><Name>FreeRun</Name><Desc>Free run</Desc><AssignActivate>0</AssignActivate></OpMode>
          <OpMode><Name>DC</Name><Desc>DC-Synchron</Desc><AssignActivate>#x300</AssignActivate>
            <CycleTimeSync0 Factor="1">0</CycleTimeSync0><ShiftTimeSync0 Input="0">-2000</ShiftTimeSync0>
            <CycleTimeSync1 Factor="0">0</CycleTimeSync1></OpMode>
        </Dc>
        <Slots MaxSlotCount="2" SlotPdoIncrement="#x10">
          <Slot MinInstances="1" MaxInstances="1"><Name>Axis</Name><ModuleIdent Default="1">#x100</ModuleIdent><ModuleIdent>#x101</ModuleIdent></Slot>
          <Slot MinInstances="0" MaxInstances="1" SlotGroup="2"><Name>Option</Name><ModuleClass><Class>IO</Class></ModuleClass></Slot>
        </Slots>
      </Device>
    </Devices>
    <Modules>
      <Module><Type ModuleIdent="#x100" ModuleClass="Axis">AX1</Type><Name>Axis module</Name>
        <TxPdo><Index>#x1A00</Index><Name>Status</Name><Entry><Index>#x6041</Index><SubIndex>0</SubIndex><BitLen>16</BitLen></Entry></TxPdo>
        <DcOpModeName>DC</DcOpModeName>
      </Module>
    </Modules>
  </Descriptions>
</EtherCATInfo>
)";

std::string modular_error_of(const std::string& from, const std::string& to) {
  std::string text = kModular;
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  const auto esi = read_esi(text, "bad.xml");
  return esi ? std::string("(read)") : esi.error().to_string();
}

TEST(EsiReader, ReadsPdoMappingFlagsOfObjectsAndSubItems) {
  // Given VARs flagged T and rt, a record whose SubItem 1 says R and whose Object says TR, and
  // an object without PdoMapping
  const auto esi = read_esi(kModular, "modular.xml");
  ASSERT_TRUE(esi) << esi.error().to_string();
  const EsiDevice& d = esi->devices[0];
  // When read; Then each entry has its directions, lower case read as upper case
  const auto* status = d.find(0x6041, 0);
  ASSERT_NE(status, nullptr);
  ASSERT_TRUE(status->pdo_mapping);
  EXPECT_TRUE(status->pdo_mapping->tx);
  EXPECT_FALSE(status->pdo_mapping->rx);
  EXPECT_EQ(status->pdo_mapping->text, "T");
  EXPECT_EQ(status->pdo_mapping->line, 19);
  const auto* control = d.find(0x6040, 0);
  ASSERT_TRUE(control && control->pdo_mapping);
  EXPECT_TRUE(control->pdo_mapping->rx && control->pdo_mapping->tx);
  // And a SubItem's own flag wins; one without takes the Object's
  const auto* out = d.find(0x7000, 1);
  ASSERT_TRUE(out && out->pdo_mapping);
  EXPECT_TRUE(out->pdo_mapping->rx);
  EXPECT_FALSE(out->pdo_mapping->tx);
  const auto* both = d.find(0x7000, 2);
  ASSERT_TRUE(both && both->pdo_mapping);
  EXPECT_TRUE(both->pdo_mapping->rx && both->pdo_mapping->tx);
  EXPECT_EQ(both->pdo_mapping->text, "TR");
  EXPECT_FALSE(d.find(0x1000, 0)->pdo_mapping);
}

TEST(EsiReader, RefusesAnUnknownPdoMappingWithItsLine) {
  // Given PdoMapping values outside the schema's enumeration, When read, Then file:line names it
  EXPECT_NE(modular_error_of("<PdoMapping>T</PdoMapping>", "<PdoMapping>X</PdoMapping>")
                .find("bad.xml:19: <PdoMapping> 'X' is none of R, T, RT, TR"),
            std::string::npos)
      << modular_error_of("<PdoMapping>T</PdoMapping>", "<PdoMapping>X</PdoMapping>");
  EXPECT_NE(modular_error_of("<PdoMapping>R</PdoMapping>", "<PdoMapping>Rt</PdoMapping>")
                .find("bad.xml:14: <PdoMapping> 'Rt'"),
            std::string::npos);
  EXPECT_NE(modular_error_of("<PdoMapping>TR</PdoMapping>", "<PdoMapping></PdoMapping>")
                .find("bad.xml:21: <PdoMapping> ''"),
            std::string::npos);
}

TEST(EsiReader, ReadsDcOpModes) {
  // Given two Dc/OpModes, When read, Then their names, AssignActivate and times
  const auto esi = read_esi(kModular, "modular.xml");
  ASSERT_TRUE(esi) << esi.error().to_string();
  const auto& modes = esi->devices[0].dc_op_modes;
  ASSERT_EQ(modes.size(), 2u);
  EXPECT_EQ(modes[0].name, "FreeRun");
  EXPECT_EQ(modes[0].assign_activate, 0);
  EXPECT_FALSE(modes[0].cycle_time_sync0);
  EXPECT_EQ(modes[1].name, "DC");
  EXPECT_EQ(modes[1].desc, "DC-Synchron");
  EXPECT_EQ(modes[1].assign_activate, 0x300);
  EXPECT_EQ(modes[1].line, 28);
  ASSERT_TRUE(modes[1].cycle_time_sync0);
  EXPECT_EQ(modes[1].cycle_time_sync0->value, 0);
  EXPECT_EQ(modes[1].cycle_time_sync0->factor, 1);
  ASSERT_TRUE(modes[1].shift_time_sync0);
  EXPECT_EQ(modes[1].shift_time_sync0->value, -2000);
  EXPECT_EQ(modes[1].shift_time_sync0->input, false);
  ASSERT_TRUE(modes[1].cycle_time_sync1);
  EXPECT_EQ(modes[1].cycle_time_sync1->factor, 0);
  EXPECT_FALSE(modes[1].shift_time_sync1);
}

TEST(EsiReader, RefusesBadDcOpModesWithTheirLine) {
  // Given an OpMode without AssignActivate, one without Name, and a time that is no xs:int
  EXPECT_NE(modular_error_of("<AssignActivate>#x300</AssignActivate>", "")
                .find("bad.xml:28: <OpMode> has no <AssignActivate>"),
            std::string::npos)
      << modular_error_of("<AssignActivate>#x300</AssignActivate>", "");
  EXPECT_NE(modular_error_of("<Name>FreeRun</Name>", "").find("bad.xml:27: <OpMode> has no <Name>"),
            std::string::npos);
  EXPECT_NE(modular_error_of("-2000</Shift", "#x10</Shift")
                .find("bad.xml:29: <ShiftTimeSync0> '#x10' is not an xs:int"),
            std::string::npos)
      << modular_error_of("-2000</Shift", "#x10</Shift");
  EXPECT_NE(modular_error_of("Factor=\"1\"", "Factor=\"one\"")
                .find("bad.xml:29: CycleTimeSync0@Factor 'one' is not an xs:int"),
            std::string::npos);
}

TEST(EsiReader, ReadsSlotsAndModules) {
  // Given a device with two slots and a file with one module
  const auto esi = read_esi(kModular, "modular.xml");
  ASSERT_TRUE(esi) << esi.error().to_string();
  // When read; Then the slots with their instances, modules (the default marked) or classes
  const auto& slots = esi->devices[0].slots;
  ASSERT_TRUE(slots);
  EXPECT_EQ(slots->max_slot_count, 2u);
  EXPECT_EQ(slots->pdo_increment, 0x10u);
  ASSERT_EQ(slots->slots.size(), 2u);
  EXPECT_EQ(slots->slots[0].name, "Axis");
  EXPECT_EQ(slots->slots[0].min_instances, 1u);
  EXPECT_EQ(slots->slots[0].module_idents, (std::vector<std::uint32_t>{0x100, 0x101}));
  EXPECT_EQ(slots->slots[0].default_ident, 0x100u);
  EXPECT_EQ(slots->slots[0].line, 33);
  EXPECT_EQ(slots->slots[1].slot_group, 2u);
  EXPECT_EQ(slots->slots[1].module_classes, (std::vector<std::string>{"IO"}));
  // And the module with its ident, class, PDOs and DC operation mode
  ASSERT_EQ(esi->modules.size(), 1u);
  const auto* module = esi->find_module(0x100);
  ASSERT_NE(module, nullptr);
  EXPECT_EQ(module->name, "Axis module");
  EXPECT_EQ(module->module_class, "Axis");
  EXPECT_EQ(module->line, 39);
  ASSERT_EQ(module->tx_pdos.size(), 1u);
  EXPECT_EQ(module->tx_pdos[0].entries.at(0).index, 0x6041);
  EXPECT_EQ(module->dc_op_mode_name, "DC");
  EXPECT_EQ(esi->find_module(0x101), nullptr);
}

TEST(EsiReader, RefusesBadSlotsAndModulesWithTheirLine) {
  // Given a slot without MaxInstances, a slot naming no module, a module without ModuleIdent, a
  // module twice and a bad ModuleIdent
  EXPECT_NE(modular_error_of("MinInstances=\"1\" MaxInstances=\"1\"", "MinInstances=\"1\"")
                .find("bad.xml:33: <Slot> has no MaxInstances (required)"),
            std::string::npos);
  EXPECT_NE(modular_error_of("<ModuleClass><Class>IO</Class></ModuleClass>", "")
                .find("bad.xml:34: <Slot> names no module"),
            std::string::npos);
  EXPECT_NE(modular_error_of("<Type ModuleIdent=\"#x100\" ", "<Type ")
                .find("bad.xml:39: <Type> has no ModuleIdent (required)"),
            std::string::npos);
  EXPECT_NE(modular_error_of("<ModuleIdent Default=\"1\">#x100</ModuleIdent>",
                             "<ModuleIdent>#xG</ModuleIdent>")
                .find("bad.xml:33: <ModuleIdent> '#xG' is not a number"),
            std::string::npos);
  EXPECT_NE(modular_error_of("<DcOpModeName>DC</DcOpModeName>\n      </Module>",
                             "</Module><Module><Type ModuleIdent=\"256\">X</Type><Name>Y</Name>"
                             "</Module>")
                .find("bad.xml:41: <Module> with ModuleIdent 00000100h is there twice"),
            std::string::npos)
      << modular_error_of("<DcOpModeName>DC</DcOpModeName>\n      </Module>",
                          "</Module><Module><Type ModuleIdent=\"256\">X</Type><Name>Y</Name>"
                          "</Module>");
  EXPECT_NE(modular_error_of("MinInstances=\"0\" MaxInstances=\"1\"",
                             "MinInstances=\"2\" MaxInstances=\"1\"")
                .find("bad.xml:34: <Slot> MinInstances 2 exceeds MaxInstances 1"),
            std::string::npos);
}

}  // namespace
}  // namespace drivecheck::ethercat
