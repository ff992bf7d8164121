"""What pipegauge talks about: the EN 13508-2 code table (``codes``) and the typed records that cross floors
(``records``): a section header, an observation as read from any format, its marks, a row's problem."""
